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

// The CHOLMOD supernodal path of the static solve (the factorisation of the large reference
// levels) against the analytic solution and the LDL^T on a block in uniaxial stress: rollers on
// x = 0, y = 0, z = 0, a uniform traction p on the top face. Linear tets represent the exact
// solution u_z = -p z / E, u_x = nu p x / E, u_y = nu p y / E, so both solvers must give it to
// round-off, and each other.
TEST(FemReference, CholmodMatchesLdltAndTheAnalyticBlock) {
  const Eigen::Vector3d size(0.03, 0.02, 0.04);
  const mesh::TetMesh b = fem_block_mesh(6, 4, 8, size, 101);
  const double E = 2e4, nu = 0.35, p = 500;  // Pa, -, Pa
  const FemSystem s = fem_precompute(b.V, b.T, uniform_materials(b.T.rows(), E, nu, 1000));
  std::vector<std::uint8_t> fixed(static_cast<size_t>(3 * b.V.rows()), 0);
  for (long i = 0; i < b.V.rows(); ++i)
    for (int a = 0; a < 3; ++a) fixed[3 * i + a] = b.V(i, a) < 1e-12;
  // Consistent load of the uniform traction on the top faces (a third per vertex).
  const mesh::BoundaryFaces bf = mesh::boundary_faces(b);
  Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * b.V.rows());
  for (long k = 0; k < bf.F.rows(); ++k) {
    bool top = true;
    for (int j = 0; j < 3; ++j) top = top && b.V(bf.F(k, j), 2) > size.z() - 1e-12;
    if (!top) continue;
    const Eigen::Vector3d x0 = mesh::row3(b.V, bf.F(k, 0)), x1 = mesh::row3(b.V, bf.F(k, 1)),
                          x2 = mesh::row3(b.V, bf.F(k, 2));
    const double area = 0.5 * (x1 - x0).cross(x2 - x0).norm();
    for (int j = 0; j < 3; ++j) f[3 * bf.F(k, j) + 2] -= p * area / 3;
  }
  Eigen::VectorXd exact(3 * b.V.rows());
  for (long i = 0; i < b.V.rows(); ++i)
    exact.segment<3>(3 * i) << nu * p * b.V(i, 0) / E, nu * p * b.V(i, 1) / E, -p * b.V(i, 2) / E;
  StaticSolver ldlt, chol, autom;
  static_precompute(s.K, fixed, ldlt, SparseSolverKind::ldlt);
  static_precompute(s.K, fixed, chol, SparseSolverKind::cholmod);
  static_precompute(s.K, fixed, autom, SparseSolverKind::automatic);
  EXPECT_EQ(ldlt.kind, SparseSolverKind::ldlt);
  EXPECT_EQ(chol.kind, SparseSolverKind::cholmod);
  EXPECT_EQ(autom.kind, SparseSolverKind::ldlt);  // 1.3k free dofs: below kCholmodMinDofs
  EXPECT_GT(chol.factor_nnz, 0);
  EXPECT_GT(ldlt.factor_nnz, 0);
  const Eigen::VectorXd ul = static_solve(ldlt, f), uc = static_solve(chol, f);
  const double umax = exact.cwiseAbs().maxCoeff();
  EXPECT_LT((ul - exact).cwiseAbs().maxCoeff(), 1e-9 * umax);
  EXPECT_LT((uc - exact).cwiseAbs().maxCoeff(), 1e-9 * umax);
  EXPECT_LT((uc - ul).cwiseAbs().maxCoeff(), 1e-11 * umax);
  // Several right-hand sides at once (the contact compliance's use).
  Eigen::MatrixXd B(static_cast<long>(chol.split.free.size()), 2);
  B.col(0) = gather(f, chol.split.free);
  B.col(1) = -2 * B.col(0);
  const Eigen::MatrixXd X = chol.solve_free(B);
  EXPECT_LT((X.col(0) - gather(ul, ldlt.split.free)).cwiseAbs().maxCoeff(), 1e-11 * umax);
  EXPECT_LT((X.col(1) + 2 * X.col(0)).cwiseAbs().maxCoeff(), 1e-11 * umax);
  // A free-floating body (no constraint) is singular for CHOLMOD too.
  StaticSolver floating;
  EXPECT_THROW(static_precompute(s.K, std::vector<std::uint8_t>(fixed.size(), 0), floating,
                                 SparseSolverKind::cholmod),
               std::runtime_error);
  // Only rollers on x = 0: rigid translations in y and z remain.
  std::vector<std::uint8_t> rollers(fixed.size(), 0);
  for (long i = 0; i < b.V.rows(); ++i) rollers[3 * i] = b.V(i, 0) < 1e-12;
  EXPECT_THROW(static_precompute(s.K, rollers, floating, SparseSolverKind::cholmod),
               std::runtime_error);
  EXPECT_EQ(parse_sparse_solver("cholmod"), SparseSolverKind::cholmod);
  EXPECT_EQ(parse_sparse_solver("auto"), SparseSolverKind::automatic);
  EXPECT_THROW(parse_sparse_solver("lu"), std::invalid_argument);
}

// The whole reference with either solver: the same levels to round-off.
TEST(FemReference, ReferenceLevelsIndependentOfTheSolver) {
  FemReferenceOptions o = nested_block_options(0, 0.5);
  o.solver = SparseSolverKind::ldlt;
  const FemReferenceResult a = fem_reference(o);
  o.solver = SparseSolverKind::cholmod;
  const FemReferenceResult b = fem_reference(o);
  ASSERT_EQ(a.levels.size(), b.levels.size());
  for (size_t l = 0; l < a.levels.size(); ++l) {
    EXPECT_EQ(a.levels[l].solver, "ldlt");
    EXPECT_EQ(b.levels[l].solver, "cholmod");
    EXPECT_NEAR(b.levels[l].stiffness / a.levels[l].stiffness, 1.0, 1e-10) << l;
  }
  EXPECT_NEAR(b.stiffness / a.stiffness, 1.0, 1e-8);
  EXPECT_NEAR(b.observed_order, a.observed_order, 1e-6);
}

// Nested levels prolongate exactly: the coarse FE function read at the fine nodes.
TEST(FemReference, ProlongationInterpolatesLinearFields) {
  const mesh::TetMesh b = fem_block_mesh(2, 2, 1, Eigen::Vector3d(0.02, 0.02, 0.01), 101);
  const RedRefinement rr = refine_red(b);
  const auto lin = [](const Eigen::Vector3d& x) {
    return Eigen::Vector3d(1 + 2 * x.x() - x.z(), 3 * x.y(), -x.x() + 0.5 * x.y() + 4 * x.z());
  };
  Eigen::VectorXd uc(3 * b.V.rows());
  for (long i = 0; i < b.V.rows(); ++i) uc.segment<3>(3 * i) = lin(mesh::row3(b.V, i));
  const Eigen::VectorXd uf = prolongate(rr.parent, uc);
  ASSERT_EQ(uf.size(), 3 * rr.mesh.V.rows());
  for (long i = 0; i < rr.mesh.V.rows(); ++i)
    EXPECT_LT((uf.segment<3>(3 * i) - lin(mesh::row3(rr.mesh.V, i))).norm(), 1e-14) << i;
}

// The trust rule (reference_untrusted_reason): a converged nested sequence passes; every way of
// not converging is named.
TEST(FemReference, TrustRuleAcceptsConvergedAndRejectsUnconverged) {
  // (The ungraded nested block above is not trusted: 14.1 mm loaded edges on level 0 against
  // its 12 mm press, and 12 % estimated error on the finest level.)
  EXPECT_NE(reference_untrusted_reason(fem_reference(nested_block_options(0, 0.5))), "");
  // Synthetic sequences with ratio 2: q = 100 + 40 h^1.5 (converged) and variants.
  const auto make = [](double k0, double k1, double k2, double press_h) {
    FemReferenceResult r;
    r.press_radius = 0.01;
    r.refinement_ratio = 2;
    const double k[3] = {k0, k1, k2};
    for (int l = 0; l < 3; ++l) {
      FemReferenceLevel lv;
      lv.stiffness = k[l];
      lv.press_h = press_h / (1 << l);
      r.levels.push_back(lv);
    }
    richardson(k0, k1, k2, 2, r.observed_order, r.stiffness);
    r.order_plausible =
        r.observed_order >= kPlausibleOrder[0] && r.observed_order <= kPlausibleOrder[1];
    r.monotone = true;
    for (int l = 0; l < 3; ++l) {
      r.levels[l].est_error = std::abs(r.levels[l].stiffness - r.stiffness) / r.stiffness;
      if (l > 0) r.monotone = r.monotone && r.levels[l].est_error < r.levels[l - 1].est_error;
    }
    return r;
  };
  const auto q = [](double h) { return 100 + 40 * std::pow(h, 1.5); };
  EXPECT_EQ(reference_untrusted_reason(make(q(1), q(0.5), q(0.25), 0.005)), "");
  // The press not resolved on the first level used.
  EXPECT_NE(reference_untrusted_reason(make(q(1), q(0.5), q(0.25), 0.0129)).find("not resolved"),
            std::string::npos);
  // Differences that grow (the 85/44/20 % of an unresolved press go the other way: shrinking
  // too slowly): order 0.3 is outside the asymptotic range.
  const auto slow = [](double h) { return 100 + 40 * std::pow(h, 0.3); };
  EXPECT_NE(reference_untrusted_reason(make(slow(1), slow(0.5), slow(0.25), 0.005))
                .find("outside the asymptotic range"),
            std::string::npos);
  // Oscillating: no order at all.
  EXPECT_NE(reference_untrusted_reason(make(120, 110, 112, 0.005)).find("do not shrink"),
            std::string::npos);
  // Converged in order but the finest level still far from the limit (large correction).
  const auto big = [](double h) { return 100 + 900 * std::pow(h, 1.0); };
  EXPECT_NE(reference_untrusted_reason(make(big(1), big(0.5), big(0.25), 0.005))
                .find("finest level's estimated error"),
            std::string::npos);
}

// Local grading of the surface around the press: conforming, the same polyhedron, the input
// vertices kept, edges under the point shrunk by 2^rounds and untouched far away.
TEST(FemReference, SurfaceGradingIsConformingAndLocal) {
  const Eigen::Vector3d size(0.04, 0.04, 0.02);
  const mesh::SurfaceMesh s = box_surface(size);  // 5 mm edges on the top face
  const Eigen::Vector3d p(0.02, 0.02, 0.02);
  const mesh::SurfaceMesh g = refine_surface_near(s, p, 0.012, 2);
  ASSERT_GT(g.F.rows(), s.F.rows());
  EXPECT_EQ((g.V.topRows(s.V.rows()) - s.V).cwiseAbs().maxCoeff(), 0.0);
  // Closed 2-manifold with consistent orientation: every edge in exactly two faces.
  EXPECT_TRUE(g.non_manifold_edges.empty());
  EXPECT_TRUE(g.inconsistent_edges.empty());
  for (long e = 0; e < g.edge_faces.size(); ++e) ASSERT_EQ(g.edge_faces[e], 2) << e;
  // Same enclosed volume and area (midpoints on straight edges).
  const auto vol_area = [](const mesh::SurfaceMesh& m) {
    double v = 0, a = 0;
    for (long k = 0; k < m.F.rows(); ++k) {
      const Eigen::Vector3d x0 = mesh::row3(m.V, m.F(k, 0)), x1 = mesh::row3(m.V, m.F(k, 1)),
                            x2 = mesh::row3(m.V, m.F(k, 2));
      v += x0.dot(x1.cross(x2)) / 6;
      a += 0.5 * (x1 - x0).cross(x2 - x0).norm();
    }
    return std::pair<double, double>(v, a);
  };
  const auto [v0, a0] = vol_area(s);
  const auto [v1, a1] = vol_area(g);
  EXPECT_NEAR(v1, v0, 1e-12 * std::abs(v0));
  EXPECT_NEAR(a1, a0, 1e-12 * a0);
  const double h_s = press_edge(s.V, s.F, p, -Eigen::Vector3d::UnitZ(), 0.005);
  const double h_g = press_edge(g.V, g.F, p, -Eigen::Vector3d::UnitZ(), 0.005);
  EXPECT_NEAR(h_g, h_s / 4, 1e-12);
  // Far from the point (the bottom face) nothing changed: the same number of bottom faces.
  const auto bottom = [](const mesh::SurfaceMesh& m) {
    long n = 0;
    for (long k = 0; k < m.F.rows(); ++k)
      n += m.V(m.F(k, 0), 2) < 1e-12 && m.V(m.F(k, 1), 2) < 1e-12 && m.V(m.F(k, 2), 2) < 1e-12;
    return n;
  };
  EXPECT_EQ(bottom(g), bottom(s));
  // The rounds that auto grading picks: loaded edges down to the press radius.
  FemReferenceOptions o;
  o.surface = s;
  o.press_point = p;
  o.press_radius = 0.005;  // 5 mm edges (diagonals 7.1 mm) -> 3.5 mm: 1 round
  EXPECT_EQ(auto_grade_rounds(o), 1);
  o.press_radius = 0.003;  // -> 1.8 mm: 2 rounds
  EXPECT_EQ(auto_grade_rounds(o), 2);
  o.press_radius = 0.02;
  EXPECT_EQ(auto_grade_rounds(o), 0);
}

// Nested levels graded around the press from level 0 (10 mm edges on the box's surface, a
// 10 mm press): two rounds of grading (auto takes one: 7.1 mm <= 10 mm) make level 0 resolve
// the pad (3.5 mm edges) and the three nested levels are in the asymptotic range; the same problem
// without grading (level 0 = TetGen of the plain surface) sees a point load on level 0.
// 4.9 s in Release (measured this session): the third level has 81k tets, the smallest a graded
// 3-level run of this press reaches.
TEST(FemReference, GradedNestedLevelsResolveThePress) {
  const Eigen::Vector3d size(0.04, 0.04, 0.02);
  FemReferenceOptions o;
  const mesh::TetMesh b = fem_block_mesh(4, 4, 2, size, 101);
  o = reference_options_from_mesh(b, 2 + 5 * (2 + 5 * 2), 1.0, 0.01);  // top centre
  o.is_fixed = [](const Eigen::Vector3d& p) { return p.z() < 1e-9; };
  o.refinement = FemRefinement::nested;
  o.base = mesh::TetMesh();
  o.max_volume = 4e-6;
  EXPECT_EQ(auto_grade_rounds(o), 1);  // 14.1 mm diagonals -> 7.1 mm <= 10 mm
  const int rounds = 2;
  // Without grading (grade_rounds 0, measured): 573, 351, 271 N/m, order 1.48, extrapolated
  // 226 N/m, 14.1 mm loaded edges on level 0 (unresolved), finest level 20 % above the limit.
  // Not rerun here (it doubles the test's time); the check that it is untrusted for the press
  // is TrustRuleAcceptsConvergedAndRejectsUnconverged's.
  o.grade_rounds = rounds;
  const FemReferenceResult r = fem_reference(o);
  for (const auto* x : {&r}) {
    for (const auto& l : x->levels)
      std::printf("%ld tets, press h %.3g mm: k %.6g N/m, est. error %.3g\n", l.tets,
                  1e3 * l.press_h, l.stiffness, l.est_error);
    std::printf("extrapolated k %.6g N/m, observed order %.3f: %s\n", x->stiffness,
                x->observed_order, reference_untrusted_reason(*x).c_str());
  }
  EXPECT_LE(r.levels[0].press_h, 0.5 * o.press_radius + 1e-12);
  EXPECT_EQ(r.levels[2].tets, 64 * r.levels[0].tets);
  EXPECT_TRUE(r.monotone);
  EXPECT_TRUE(r.order_plausible);
  // Measured: 374, 272, 239 N/m, order 1.64, extrapolated 223 N/m (the ungraded levels: 226
  // N/m, order 1.48, unresolved). The finest level is still 7 % above the limit here (level 0
  // is coarse away from the pad: 4 cm^3 tets): trusted with a 10 % bound on that correction,
  // not with the default 5 %, which the graded test must therefore still name.
  EXPECT_EQ(reference_untrusted_reason(r, 0.1), "");
  EXPECT_NE(reference_untrusted_reason(r).find("finest level's estimated error"),
            std::string::npos);
  EXPECT_LT(r.levels[2].est_error, 0.198);        // the ungraded finest level's
  EXPECT_NEAR(r.stiffness / 226.455, 1.0, 0.03);  // the ungraded extrapolation agrees
  ASSERT_EQ(r.field.rows(), o.surface.V.rows());
}
