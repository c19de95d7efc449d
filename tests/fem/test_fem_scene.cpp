// Model "fem" behind the Scene (prototype D, issue 12): D and D_corot build and report their FEM
// facts; scripted presses give finite forces that reach the target; a held press settles on the
// static FEM solution of the same patch load (an independent static solve with the contact
// compliance g^T K^-1 g); the condensed model equals the full one at equilibrium (1e-8); the
// co-rotational model equals the linear one for a small press.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <utility>

#include "common/input_error.hpp"
#include "engine/haptics/clock.hpp"
#include "engine/haptics/press.hpp"
#include "engine/mesh/materials.hpp"
#include "engine/models/model.hpp"
#include "engine/solvers/fem_assembly.hpp"
#include "engine/solvers/fem_static.hpp"
#include "prototypes/factory.hpp"
#include "tests/fem/quasi_static.hpp"
#include "tests/prototypes/prototype_text.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {

using palplab::engine::testing::proto;

nlohmann::json fem_info(const Scene& s) {
  const SceneStats st = s.stats();
  EXPECT_FALSE(st.model_info.empty());
  return nlohmann::json::parse(st.model_info).at("fem");
}

// Holds the device `depth` m inside the rest surface at surface node `node` for `steps` steps
// (the press script started at that depth: a step input) and returns the force on the hand.
Eigen::Vector3d hold(Scene& s, int node, double depth, int steps) {
  PressSpec spec = press_at(s.geometry(), node, 1.0, 1e9, 0.0);
  spec.depth = depth;
  spec.start_offset = -depth;
  PressDevice press(spec);
  Rendered last;
  const long n = run_lockstep(s, press, {.duration = steps * s.dt(), .frame_period = 0.0},
                              [&](const Rendered& r, const Sample&) { last = r; });
  EXPECT_EQ(n, steps);
  EXPECT_EQ(s.last_sample().contact_node, node);
  return last.force;
}

using palplab::engine::testing::quasi_static;

}  // namespace

TEST(FemScene, DAndDCorotBuildAndReportTheirFem) {
  for (const auto& [id, form] : {std::pair<std::string, std::string>{"D", "linear"},
                                 {"D_corot", "corotational"},
                                 {"D_multirate", "corotational_multirate"}}) {
    const Scene s = prototypes::build_scene(proto(id));
    EXPECT_STREQ(s.model_kind(), "fem");
    EXPECT_EQ(s.prototype(), id);
    const nlohmann::json f = fem_info(s);
    EXPECT_EQ(f.at("formulation"), form);
    const SceneStats st = s.stats();
    // Every node not pinned is solved (3 dofs each); the base (fixed_z_below) is pinned.
    EXPECT_GT(f.at("dofs").get<long>(), 1000);
    EXPECT_LT(f.at("dofs").get<long>(), 3 * st.nodes);
    EXPECT_EQ(f.at("total_dofs").get<long>(), 3 * st.nodes);
    EXPECT_GE(f.at("factor_ms").get<double>(), 0.0);
    EXPECT_FALSE(f.at("solver").get<std::string>().empty());
    EXPECT_GT(st.total_mass, 0.0);
    EXPECT_EQ(st.max_rest_error, 0.0);
    EXPECT_EQ(f.contains("update_rate_hz"), id == "D_multirate");
    if (id == "D_multirate") {
      EXPECT_EQ(f.at("update_rate_hz").get<double>(), 60.0);
    }
  }
}

// The multi-rate co-rotational D through the Scene (quasi-static by construction; here every
// step is an update, h = 5 s > 1/60 s): a 3 mm press renders a force within a few per cent of
// the linear D's static force, along the same normal, as D_corot does (its exact relations —
// linear before the first update, O(strain) from linear at small load, the co-rotational
// equilibrium at a hold, the ramp bound — are tested on a column in test_fem_multirate.cpp).
TEST(FemScene, MultirateMatchesLinearForASmallStrainPress) {
  Scene sl = make_scene(quasi_static("D")), sm = make_scene(quasi_static("D_multirate"));
  const int node = press_node(sl.geometry(), "ovary_left");
  const Eigen::Vector3d Fl = hold(sl, node, 0.003, 60), Fm = hold(sm, node, 0.003, 8);
  std::printf("3 mm: linear %.8g N, multi-rate %.8g N\n", Fl.norm(), Fm.norm());
  EXPECT_GT(Fl.norm(), 0.5);
  EXPECT_NEAR(Fm.norm(), Fl.norm(), 0.05 * Fl.norm());
  EXPECT_LT((Fm.normalized() - Fl.normalized()).norm(), 1e-9);
  EXPECT_GE(fem_info(sm).at("relinearisations").get<long>(), 2);
}

TEST(FemScene, ScriptedPressReachesTheForceAndReleases) {
  Scene s = prototypes::build_scene(proto("D"));
  const SceneGeometry& g = s.geometry();
  const int node = press_node(g, "ovary_left");
  PressDevice press(press_at(g, node, 2.0, 0.05, 0.3));
  double peak = 0;
  bool finite = true;
  LockstepOptions o;
  o.duration = 1e6;
  o.frame_period = 0;
  run_lockstep(s, press, o, [&](const Rendered& r, const Sample&) {
    finite = finite && r.force.allFinite();
    peak = std::max(peak, r.force.norm());
  });
  EXPECT_TRUE(finite);
  EXPECT_TRUE(press.force_reached());
  EXPECT_NEAR(peak, 2.0, 0.3);
  const SceneStats st = s.stats();
  EXPECT_EQ(st.divergences, 0);
  EXPECT_FALSE(st.nan_detected);
  // Released and damped: back near rest (well below the press's millimetres).
  EXPECT_LT(st.max_rest_error, 1e-3);
}

// The co-rotational step costs tens of ms (re-assembly, SVD per tet, refactorisation), so D_corot
// is checked quasi-statically: a 3 mm press (small strain) gives a finite force within a few
// per cent of the linear model's, and the same direction.
TEST(FemScene, CorotationalPressMatchesLinearForSmallStrain) {
  Scene sl = make_scene(quasi_static("D")), sc = make_scene(quasi_static("D_corot"));
  const int node = press_node(sl.geometry(), "ovary_left");
  const Eigen::Vector3d Fl = hold(sl, node, 0.003, 12), Fc = hold(sc, node, 0.003, 12);
  ASSERT_TRUE(Fc.allFinite());
  EXPECT_GT(Fl.norm(), 0.5);
  EXPECT_NEAR(Fc.norm(), Fl.norm(), 0.05 * Fl.norm());
  EXPECT_LT((Fc.normalized() - Fl.normalized()).norm(), 1e-9);  // both along the node normal
}

// The equilibrium of the held press against an independent static solve: the patch (surface
// nodes within patch_radius of the contact node, reached through tet edges, weights = lumped
// surface area) gets the load -w_i k d n, so with the compliance c = g^T K_ff^-1 g
// (g = sum_i w_i e_i n) the penetration is d = d0 / (1 + k c) and the force k d.
TEST(FemScene, HeldPressSettlesOnTheStaticFemSolution) {
  const SceneConfig cfg = quasi_static("D");
  Scene s = make_scene(cfg);
  const SceneGeometry& g = s.geometry();
  const int node = press_node(g, "ovary_left");
  const double depth = 0.003;
  const Eigen::Vector3d F = hold(s, node, depth, 60);

  const auto cm = scene_mesh(cfg.mesh);
  const long nm = cm->model_V.rows();
  const mesh::TetMesh tm = mesh::make_tet_mesh(cm->model_V, cm->model_T, cm->tet_attribute);
  TetMaterials mat = tet_materials(tm, mesh::default_materials());
  for (long t = 0; t < tm.T.rows(); ++t) mat.youngs_modulus[t] = *cfg.material.youngs_modulus;
  const FemSystem sys = fem_precompute(tm.V, tm.T, mat);
  std::vector<std::uint8_t> fixed(nm, 0);
  const double z0 = cm->model_V.col(2).minCoeff();
  for (long i = 0; i < nm; ++i) fixed[i] = cm->model_V(i, 2) < z0 + cfg.support.fixed_z_below;
  // The patch, by its definition (fem_scene_model.cpp), and the foundation (kappa x area).
  Eigen::VectorXd area = Eigen::VectorXd::Zero(nm);
  for (size_t i = 0; i < cm->surface_to_model.size(); ++i)
    area[cm->surface_to_model[i]] = cm->vertex_area[static_cast<long>(i)];
  ASSERT_GT(cfg.support.modulus, 0);
  SparseMatrixd K = sys.K;
  for (long i = 0; i < nm; ++i)
    for (int c = 0; c < 3; ++c) K.coeffRef(3 * i + c, 3 * i + c) += cfg.support.modulus * area[i];
  StaticSolver ss;
  static_precompute(K, node_to_dof_flags(fixed), ss);

  const int p = cm->surface_to_model[node];
  const Eigen::Vector3d c0 = cm->model_V.row(p).transpose();
  std::vector<int> patch = {p};
  std::vector<std::uint8_t> mark(nm, 0);
  mark[p] = 1;
  for (size_t q = 0; q < patch.size(); ++q)
    for (long e = 0; e < cm->model_E.rows(); ++e) {
      int j = -1;
      if (cm->model_E(e, 0) == patch[q]) j = cm->model_E(e, 1);
      if (cm->model_E(e, 1) == patch[q]) j = cm->model_E(e, 0);
      if (j < 0 || mark[j] || !(area[j] > 0) ||
          (cm->model_V.row(j).transpose() - c0).norm() > cfg.contact.patch_radius)
        continue;
      mark[j] = 1;
      patch.push_back(j);
    }
  ASSERT_GT(patch.size(), 3u);  // a face, not a point
  double sum = 0;
  for (int i : patch) sum += area[i];
  const Eigen::Vector3d n = g.N.row(node).transpose();
  const Eigen::Vector3d x = g.V.row(node).transpose() - depth * n;
  Eigen::VectorXd gv = Eigen::VectorXd::Zero(3 * nm);
  double d0 = 0;
  for (int i : patch) {
    const double w = area[i] / sum;
    const Eigen::Vector3d xi = cm->model_V.row(i).transpose();
    d0 += w * ((xi - x).dot(n) - std::max(0.0, (xi - c0).dot(n)));
    if (!fixed[i]) gv.segment<3>(3 * i) += w * n;
  }
  const double k = cfg.contact.stiffness;
  const double compliance = gv.dot(static_solve(ss, gv));
  const double f_static = k * d0 / (1 + k * compliance);
  EXPECT_GT(f_static, 0.5);  // a real press (about 2 N)
  EXPECT_NEAR(F.norm(), f_static, 1e-8 * f_static);
  EXPECT_LT((F.normalized() - n).norm(), 1e-12);
}

// The hybrid condensed model solves only the operational region and its interface; through the
// Scene, at equilibrium, it renders the force of the full linear model (issue: 1e-8 relative).
TEST(FemScene, CondensedEqualsFullAtEquilibriumThroughTheScene) {
  SceneConfig full = quasi_static("D");
  SceneConfig cond = full;
  cond.fem.formulation = FemFormulation::condensed;
  cond.fem.operational_region = "ovary_left";
  cond.fem.operational_radius = 0.015;
  Scene sf = make_scene(full), sc = make_scene(cond);
  const int node = press_node(sf.geometry(), "ovary_left");
  const Eigen::Vector3d Ff = hold(sf, node, 0.003, 60);
  const Eigen::Vector3d Fc = hold(sc, node, 0.003, 60);
  const nlohmann::json fc = fem_info(sc), ff = fem_info(sf);
  EXPECT_EQ(fc.at("formulation"), "condensed");
  EXPECT_LT(fc.at("dofs").get<long>(), ff.at("dofs").get<long>() / 2);  // a real reduction
  EXPECT_GT(Ff.norm(), 0.5);
  EXPECT_LT((Fc - Ff).norm(), 1e-8 * Ff.norm());
  // The recovered interior matches too (graphics): the largest displacement.
  EXPECT_NEAR(sc.stats().max_rest_error, sf.stats().max_rest_error,
              1e-8 * sf.stats().max_rest_error);
  // Outside the operational region the condensed model renders the inverse-stiffness contact
  // of the full linear model: from the first step, the force the full model settles on.
  const int far = press_node(sc.geometry(), "ovary_right");
  sc.reset();
  sf.reset();
  const Eigen::Vector3d Fr = hold(sc, far, 0.003, 2);
  const Eigen::Vector3d Frf = hold(sf, far, 0.003, 60);
  EXPECT_EQ(fem_info(sc).at("outside_contacts").get<long>(), 2);
  EXPECT_GT(Frf.norm(), 0.3);
  EXPECT_LT(Fr.norm(), 0.9 * cond.contact.stiffness * 0.003);  // not rigid
  EXPECT_LT((Fr - Frf).norm(), 1e-8 * Frf.norm());
}

TEST(FemScene, BadConfigsAreInputErrors) {
  SceneConfig c = prototypes::load_prototype(proto("D"));
  c.fem.formulation = FemFormulation::condensed;  // no operational region
  EXPECT_THROW(make_scene(c), InputError);
  c.fem.operational_region = "no_such_region";
  EXPECT_THROW(make_scene(c), InputError);
  SceneConfig free = prototypes::load_prototype(proto("D"));
  free.support.fixed_z_below = 0;  // nothing pinned and no foundation: the body floats
  free.support.modulus = 0;
  EXPECT_THROW(make_scene(free), InputError);
  // update_rate_hz belongs to the multi-rate formulation only, and must be in range.
  for (const std::string& bad :
       {std::string("\"formulation\": \"linear\", \"update_rate_hz\": 60"),
        std::string("\"formulation\": \"corotational_multirate\", \"update_rate_hz\": 0"),
        std::string("\"formulation\": \"linear\", \"deterministic_update\": true")}) {
    const std::string path = ::testing::TempDir() + "/bad_multirate.json";
    std::ifstream in(proto("D_multirate"));
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto a = text.find("\"formulation\"");
    const auto b = text.find("\"jacobian\"");
    text.replace(a, b - a, bad + ",\n    ");
    std::ofstream(path) << text;
    EXPECT_THROW(prototypes::load_prototype(path), InputError) << bad;
  }
  SceneConfig surf = prototypes::load_prototype(proto("D"));
  surf.mesh.generator = "tract";  // a surface mesh
  EXPECT_THROW(make_scene(surf), InputError);
}
