// The accuracy reference (issue 12): Richardson extrapolation on its own, and fem_reference on a
// verification block (TetGen refinements of the same box surface, max volume halved per level).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <utility>

#include "common/input_error.hpp"
#include "engine/haptics/press.hpp"
#include "engine/models/fem_block_mesh.hpp"
#include "engine/models/fem_reference.hpp"
#include "engine/models/fem_refine.hpp"
#include "engine/models/model.hpp"
#include "prototypes/factory.hpp"

using namespace palplab;
using namespace palplab::engine;

TEST(FemReference, RichardsonRecoversAKnownLimitAndOrder) {
  // q(h) = 2 + 0.5 h^2 on h = 1, r^-1, r^-2.
  const double r = std::cbrt(2.0);
  auto q = [](double h) { return 2 + 0.5 * h * h; };
  double p, lim;
  ASSERT_TRUE(richardson(q(1), q(1 / r), q(1 / (r * r)), r, p, lim));
  EXPECT_NEAR(p, 2.0, 1e-10);
  EXPECT_NEAR(lim, 2.0, 1e-12);
  EXPECT_FALSE(richardson(1, 2, 1.5, r, p, lim));  // oscillating: no extrapolation
  // Non-uniform sizes: q = 3 - 0.2 h^1.5 on h = 1, 0.7, 0.4.
  const double h[3] = {1, 0.7, 0.4};
  double qs[3];
  for (int i = 0; i < 3; ++i) qs[i] = 3 - 0.2 * std::pow(h[i], 1.5);
  ASSERT_TRUE(richardson_sizes(qs, h, p, lim));
  EXPECT_NEAR(p, 1.5, 1e-9);
  EXPECT_NEAR(lim, 3.0, 1e-10);
}

namespace {
mesh::SurfaceMesh box_surface(const Eigen::Vector3d& size) {
  const mesh::TetMesh b = fem_block_mesh(8, 8, 4, size, 101);
  const mesh::BoundaryFaces bf = mesh::boundary_faces(b);
  std::vector<int> map(b.V.rows(), -1);
  mesh::Positions V(0, 3);
  std::vector<Eigen::Vector3d> pts;
  mesh::Faces F(bf.F.rows(), 3);
  for (long f = 0; f < bf.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      int& v = map[bf.F(f, k)];
      if (v < 0) {
        v = static_cast<int>(pts.size());
        pts.push_back(mesh::row3(b.V, bf.F(f, k)));
      }
      F(f, k) = v;
    }
  V.resize(static_cast<long>(pts.size()), 3);
  for (size_t i = 0; i < pts.size(); ++i) V.row(static_cast<long>(i)) = pts[i].transpose();
  return mesh::make_surface_mesh(V, F);
}
}  // namespace

// Structured verification blocks refined by 2 (nested): the estimated error of each level
// falls monotonically and the observed order is that of linear elements.
TEST(FemReference, RichardsonEstimateMonotoneOnVerificationBlock) {
  const Eigen::Vector3d size(0.04, 0.04, 0.02);
  FemReferenceOptions o;
  o.surface = box_surface(size);
  o.is_fixed = [](const Eigen::Vector3d& p) { return p.z() < 1e-9; };
  o.press_point = Eigen::Vector3d(0.02, 0.02, 0.02);
  o.press_direction = -Eigen::Vector3d::UnitZ();
  o.force = 0.5;
  o.press_radius = 0.012;
  o.levels = 3;
  o.refinement_ratio = 2;
  // Level l: a (4 2^l, 4 2^l, 2 2^l) block (nested refinement, mesh size ratio 2).
  o.mesher = [&](int l) {
    const int k = 1 << l;
    return fem_block_mesh(4 * k, 4 * k, 2 * k, size, 101);
  };
  const FemReferenceResult r = fem_reference(o);
  ASSERT_EQ(r.levels.size(), 3u);
  for (const auto& l : r.levels)
    std::printf("%ld nodes, %ld tets: k %.6g N/m, est. error %.3g\n", l.nodes, l.tets, l.stiffness,
                l.est_error);
  std::printf("extrapolated k %.6g N/m, observed order %.3g\n", r.stiffness, r.observed_order);
  EXPECT_TRUE(r.monotone);
  EXPECT_LT(r.levels[1].stiffness, r.levels[0].stiffness);  // linear tets are too stiff
  EXPECT_LT(r.levels[2].stiffness, r.levels[1].stiffness);
  EXPECT_GT(r.observed_order, 1.0);
  EXPECT_LT(r.observed_order, 3.0);
  EXPECT_TRUE(r.order_plausible);
  EXPECT_EQ(r.field.rows(), 0);
}

// The TetGen path (max volume halved per level) runs end to end on the box surface; its
// levels are not nested, so only sanity is asserted (see the caveat in fem_reference.hpp).
// Measured here: k 367, 342, 327 N/m, extrapolated 326 N/m with an implausible order 8.4 —
// the mean tet size does not describe the resolution under the press; the nested structured
// refinement above (order 1.5) gives 284 N/m for the same problem.
TEST(FemReference, TetgenLevelsOnBoxSurface) {
  const Eigen::Vector3d size(0.04, 0.04, 0.02);
  FemReferenceOptions o;
  o.surface = box_surface(size);
  o.is_fixed = [](const Eigen::Vector3d& p) { return p.z() < 1e-9; };
  o.press_point = Eigen::Vector3d(0.02, 0.02, 0.02);
  o.force = 0.5;
  o.press_radius = 0.012;
  o.max_volume = 4e-8;
  o.quality = 1.414;
  const FemReferenceResult r = fem_reference(o);
  ASSERT_EQ(r.levels.size(), 3u);
  for (const auto& l : r.levels)
    std::printf(
        "max_volume %.3g (h %.4g m): %ld nodes, %ld tets: k %.6g N/m, est. error %.3g, "
        "field %.3g\n",
        l.max_volume, l.mesh_size, l.nodes, l.tets, l.stiffness, l.est_error, l.field_error);
  std::printf("extrapolated k %.6g N/m, order %.3g, monotone %d\n", r.stiffness, r.observed_order,
              r.monotone);
  EXPECT_GT(r.levels[2].tets, r.levels[0].tets);
  EXPECT_LT(r.levels[2].stiffness, r.levels[0].stiffness);
  EXPECT_EQ(r.order_plausible,
            r.observed_order >= kPlausibleOrder[0] && r.observed_order <= kPlausibleOrder[1]);
  for (const auto& l : r.levels) {
    EXPECT_GT(l.stiffness, 0.0);
    EXPECT_GE(l.tets * l.max_volume, size.prod() * 0.99);  // mean tet volume <= the bound
  }
  EXPECT_EQ(r.field.rows(), o.surface.V.rows());
  o.press_point = Eigen::Vector3d(1, 1, 1);
  EXPECT_THROW(fem_reference(o), InputError);
  o.levels = 2;
  EXPECT_THROW(fem_reference(o), InputError);
}

TEST(FemReference, OptionsFromAnExistingMesh) {
  const mesh::TetMesh b = fem_block_mesh(4, 4, 2, Eigen::Vector3d(0.04, 0.04, 0.02), 101);
  const int top = 2 + 5 * (2 + 5 * 2);  // node (2, 2, 2): centre of the top face
  FemReferenceOptions o = reference_options_from_mesh(b, top, 0.5, 0.012);
  EXPECT_EQ(o.surface.V.rows(), 5 * 5 * 3 - 3 * 3);  // all 75 nodes but the 9 interior ones
  EXPECT_LT((o.press_direction + Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  EXPECT_NEAR(o.max_volume, 0.04 * 0.04 * 0.02 / 192, 1e-15);
  EXPECT_EQ(o.default_attribute, 101);
  o.is_fixed = [](const Eigen::Vector3d& p) { return p.z() < 1e-9; };
  o.quality = 1.414;
  o.max_volume /= 4;
  const FemReferenceResult r = fem_reference(o);
  EXPECT_EQ(r.levels.size(), 3u);
  EXPECT_GT(r.levels[0].stiffness, r.levels[2].stiffness);
  const int interior = 2 + 5 * (2 + 5 * 1);  // node (2, 2, 1)
  EXPECT_THROW(reference_options_from_mesh(b, interior, 0.5, 0.01), InputError);
}

// Red refinement (fem_refine.hpp): eight positive children per tet that tile it exactly, the
// coarse vertices kept at their indices, midpoints at the edge midpoints, attributes inherited,
// and a bounded shape quality over two refinements (the shortest-diagonal octahedron split).
TEST(FemReference, RedRefinementIsNestedAndConforming) {
  mesh::TetMesh m = fem_block_mesh(2, 2, 1, Eigen::Vector3d(0.04, 0.03, 0.02), 101, 0.2, 3);
  m.attribute[0] = 102;
  double q0 = 1;
  for (long t = 0; t < m.T.rows(); ++t)
    q0 = std::min(q0, mesh::radius_ratio(mesh::row3(m.V, m.T(t, 0)), mesh::row3(m.V, m.T(t, 1)),
                                         mesh::row3(m.V, m.T(t, 2)), mesh::row3(m.V, m.T(t, 3))));
  mesh::TetMesh cur = m;
  for (int level = 1; level <= 2; ++level) {
    const RedRefinement r = refine_red(cur);
    const mesh::TetMesh& f = r.mesh;
    ASSERT_EQ(f.T.rows(), 8 * cur.T.rows());
    EXPECT_EQ(f.V.topRows(cur.V.rows()), cur.V);
    ASSERT_EQ(static_cast<long>(r.parent.size()), f.V.rows());
    for (long i = cur.V.rows(); i < f.V.rows(); ++i)
      EXPECT_LT((f.V.row(i) - 0.5 * (cur.V.row(r.parent[i][0]) + cur.V.row(r.parent[i][1]))).norm(),
                1e-15);
    // #V_fine = #V + #edges (Euler: every edge gets exactly one midpoint).
    std::set<std::pair<int, int>> edges;
    for (long t = 0; t < cur.T.rows(); ++t)
      for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b) edges.insert(std::minmax(cur.T(t, a), cur.T(t, b)));
    EXPECT_EQ(f.V.rows(), cur.V.rows() + static_cast<long>(edges.size()));
    Eigen::VectorXd child_sum = Eigen::VectorXd::Zero(cur.T.rows());
    double q = 1;
    for (long t = 0; t < f.T.rows(); ++t) {
      EXPECT_GT(mesh::signed_volume(f.V, f.T, static_cast<int>(t)), 0) << t;
      child_sum[r.parent_tet[t]] += f.volume[t];
      EXPECT_EQ(f.attribute[t], cur.attribute[r.parent_tet[t]]);
      q = std::min(q, mesh::radius_ratio(mesh::row3(f.V, f.T(t, 0)), mesh::row3(f.V, f.T(t, 1)),
                                         mesh::row3(f.V, f.T(t, 2)), mesh::row3(f.V, f.T(t, 3))));
    }
    EXPECT_LT((child_sum - cur.volume).cwiseAbs().maxCoeff(), 1e-12 * cur.volume.maxCoeff());
    // Boundary: 4 children per coarse boundary face (the surface is refined, not moved).
    EXPECT_EQ(mesh::boundary_faces(f).F.rows(), 4 * mesh::boundary_faces(cur).F.rows());
    std::printf("level %d: %ld tets, min radius ratio %.3f (coarse %.3f)\n", level, f.T.rows(), q,
                q0);
    EXPECT_GT(q, 0.3 * q0);
    cur = f;
  }
}

// The smooth press load: total force exactly N along the direction, the profile integral
// pi a^2 / 3 on a flat face, and its first moment at the press point (symmetric profile;
// sum_j x_j f_j = int p x dA exactly for linear shape functions).
TEST(FemReference, SmoothPressLoadIntegratesTheProfile) {
  const mesh::TetMesh b = fem_block_mesh(6, 6, 2, Eigen::Vector3d(0.06, 0.06, 0.02), 101);
  const mesh::BoundaryFaces bf = mesh::boundary_faces(b);
  const Eigen::Vector3d c(0.031, 0.028, 0.02), dir(0.2, -0.1, -1);
  const double a = 0.012, force = 2.5;
  const PressLoad L = smooth_press_load(b.V, bf.F, c, dir, force, a);
  Eigen::Vector3d total = Eigen::Vector3d::Zero(), moment = Eigen::Vector3d::Zero();
  for (long i = 0; i < b.V.rows(); ++i) {
    total += L.f.segment<3>(3 * i);
    moment += b.V(i, 0) * L.f.segment<3>(3 * i);  // x-moment of each component
  }
  EXPECT_LT((total - force * dir.normalized()).norm(), 1e-12 * force);
  const double exact = M_PI * a * a / 3;
  std::printf("profile integral %.12g, pi a^2/3 %.12g, rel %.3g\n", L.profile_integral, exact,
              L.profile_integral / exact - 1);
  EXPECT_NEAR(L.profile_integral / exact, 1.0, 1e-6);
  EXPECT_LT((moment - c.x() * force * dir.normalized()).norm(), 1e-6 * force * c.x());
  EXPECT_GT(L.patch_area, exact);
  EXPECT_THROW(smooth_press_load(b.V, bf.F, Eigen::Vector3d(1, 1, 1), dir, force, a), InputError);
}

namespace {
FemReferenceOptions nested_block_options(int curve_steps, double force, int n = 4) {
  const mesh::TetMesh b = fem_block_mesh(n, n, n / 2, Eigen::Vector3d(0.04, 0.04, 0.02), 101);
  const int c = n / 2;
  const int top = c + (n + 1) * (c + (n + 1) * (n / 2));  // the centre of the top face
  FemReferenceOptions o = reference_options_from_mesh(b, top, force, 0.012);
  o.is_fixed = [](const Eigen::Vector3d& p) { return p.z() < 1e-9; };
  o.refinement = FemRefinement::nested;
  o.curve_steps = curve_steps;
  return o;
}
}  // namespace

// Nested red refinements of the verification block (4 x 4 x 2 hexes, 6 tets each): compliance
// grows monotonically (nested spaces), the estimate is monotone and the observed order is in
// the asymptotic range of linear tets, kPlausibleOrder = [0.8, 2.5] (measured 1.4: the pinned
// base's rim limits it below 2). The extrapolated field has one row per surface vertex.
TEST(FemReference, NestedRefinementOfTheVerificationBlock) {
  const FemReferenceOptions o = nested_block_options(0, 0.5);
  const FemReferenceResult r = fem_reference(o);
  ASSERT_EQ(r.levels.size(), 3u);
  for (const auto& l : r.levels)
    std::printf("%ld tets, h %.4g: k %.8g N/m, est. error %.3g, field %.3g\n", l.tets, l.mesh_size,
                l.stiffness, l.est_error, l.field_error);
  std::printf("extrapolated k %.8g N/m, observed order %.3f\n", r.stiffness, r.observed_order);
  EXPECT_DOUBLE_EQ(r.refinement_ratio, 2.0);
  EXPECT_NEAR(r.levels[1].mesh_size / r.levels[2].mesh_size, 2.0, 1e-12);
  EXPECT_LT(r.levels[1].stiffness, r.levels[0].stiffness);
  EXPECT_LT(r.levels[2].stiffness, r.levels[1].stiffness);
  EXPECT_GT(r.levels[2].stiffness, r.stiffness);
  EXPECT_TRUE(r.monotone);
  EXPECT_GE(r.observed_order, kPlausibleOrder[0]);
  EXPECT_LE(r.observed_order, kPlausibleOrder[1]);
  EXPECT_TRUE(r.order_plausible);
  ASSERT_EQ(r.field.rows(), o.surface.V.rows());
  EXPECT_LT(r.levels[2].field_error, r.levels[1].field_error);
  EXPECT_LT(r.levels[1].field_error, r.levels[0].field_error);
}

// The quasi-static curve (co-rotational, load ramp): at a small load it is the linear static
// response of the same level (relative difference O(strain)); at a large load it is not linear
// any more but the same order of magnitude; every step converged.
TEST(FemReference, QuasiStaticCurveStartsOnTheLinearStiffness) {
  FemReferenceOptions o = nested_block_options(4, 1e-5, 2);
  o.levels = 3;
  const FemReferenceResult small = fem_reference(o);
  ASSERT_EQ(small.curve.size(), 4u);
  for (const auto& lv : small.levels) {
    ASSERT_EQ(lv.curve_displacement.size(), 4u);
    for (int k = 0; k < 4; ++k) {
      const double linear = lv.displacement * (k + 1) / 4.0;
      EXPECT_NEAR(lv.curve_displacement[k] / linear, 1.0, 1e-5) << k;
      EXPECT_GE(lv.curve_iterations[k], 1);
    }
  }
  for (const auto& c : small.curve) {
    std::printf("F %.3g N: u %.8g m (linear %.8g m), order %.4f%s\n", c.force, c.displacement,
                c.linear_displacement, c.observed_order, c.extrapolated ? ", extrapolated" : "");
    EXPECT_TRUE(c.extrapolated);
    EXPECT_NEAR(c.observed_order, small.observed_order, 1e-4);
    EXPECT_NEAR(c.secant_stiffness / small.stiffness, 1.0, 1e-5);
  }
  o.force = 0.3;  // ~ 1 mm on a 2 cm block (k ~ 300 N/m): mildly geometrically nonlinear
  const FemReferenceResult big = fem_reference(o);
  for (const auto& lv : big.levels) {
    for (size_t k = 0; k < lv.curve_displacement.size(); ++k)
      std::printf("  level %ld tets: F %.3g u %.6g (linear %.6g) iterations %d\n", lv.tets,
                  big.curve[k].force, lv.curve_displacement[k], lv.displacement * (k + 1) / 4.0,
                  lv.curve_iterations[k]);
    std::printf("  curve %.1f ms\n", lv.curve_ms);
  }
  const auto& last = big.curve.back();
  std::printf("F %.3g N: u %.6g m (linear %.6g m), secant k %.6g N/m (linear %.6g N/m)\n",
              last.force, last.displacement, last.linear_displacement, last.secant_stiffness,
              big.stiffness);
  EXPECT_GT(std::abs(last.displacement / last.linear_displacement - 1), 1e-3);
  EXPECT_LT(std::abs(last.displacement / last.linear_displacement - 1), 0.15);
  EXPECT_NEAR(big.stiffness, small.stiffness, 1e-9 * small.stiffness);  // static is linear
}

// D's press (prototype D's body, tissue, foundation and pinned base; `ovary_left` at 2.5 N) on
// nested levels of the smallest Model-C tract the generator makes (400 surface vertices: 1.5k,
// 12k, 97k tets). Measured: k = 650, 607, 585 N/m, observed order 1.01, extrapolated 564 N/m,
// monotone — against TetGen levels on the full D (622/614/607 N/m, order 0.38, untrusted).
// ~5 s CPU in Release (the 97k-tet level is the smallest third nested level of the tract: the
// test exceeds the 5 s guideline for that reason); the
// order range is the stated kPlausibleOrder.
TEST(FemReference, NestedLevelsOfDsPressAreTrusted) {
  SceneConfig cfg =
      prototypes::load_prototype(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/D.json");
  cfg.mesh.vertices = 400;
  const auto cm = scene_mesh(cfg.mesh);
  ASSERT_TRUE(cm->tet);
  const Scene scene = make_scene(cfg);
  const int node = press_node(scene.geometry(), "ovary_left");
  const mesh::TetMesh tm = mesh::make_tet_mesh(cm->model_V, cm->model_T, cm->tet_attribute);
  FemReferenceOptions o =
      reference_options_from_mesh(tm, cm->surface_to_model[node], 2.5, cfg.contact.patch_radius);
  for (auto& e : o.materials.materials)
    if (e.first <= o.default_attribute && o.default_attribute <= e.last)
      e.youngs_modulus = *cfg.material.youngs_modulus;
  o.support_modulus = cfg.support.modulus;
  const double zf = cm->model_V.col(2).minCoeff() + cfg.support.fixed_z_below;
  o.is_fixed = [zf](const Eigen::Vector3d& p) { return p.z() < zf; };
  o.refinement = FemRefinement::nested;
  const FemReferenceResult r = fem_reference(o);
  for (const auto& l : r.levels)
    std::printf("%ld tets: k %.6g N/m, est. error %.3g, field %.3g, %.0f ms\n", l.tets, l.stiffness,
                l.est_error, l.field_error, l.solve_ms);
  std::printf("extrapolated k %.6g N/m, observed order %.3f\n", r.stiffness, r.observed_order);
  EXPECT_EQ(r.levels[2].tets, 64 * r.levels[0].tets);
  EXPECT_LT(r.levels[1].stiffness, r.levels[0].stiffness);
  EXPECT_LT(r.levels[2].stiffness, r.levels[1].stiffness);
  EXPECT_TRUE(r.monotone);
  EXPECT_GE(r.observed_order, kPlausibleOrder[0]);
  EXPECT_LE(r.observed_order, kPlausibleOrder[1]);
  EXPECT_TRUE(r.order_plausible);
  EXPECT_GT(r.stiffness, 0.8 * r.levels[2].stiffness);
  EXPECT_LT(r.levels[2].field_error, r.levels[1].field_error);
}
