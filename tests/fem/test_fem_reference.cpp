// The accuracy reference (issue 12): Richardson extrapolation on its own, and fem_reference on a
// verification block (TetGen refinements of the same box surface, max volume halved per level).
#include <gtest/gtest.h>

#include "common/input_error.hpp"
#include "engine/models/fem_block_mesh.hpp"
#include "engine/models/fem_reference.hpp"

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
  EXPECT_EQ(r.order_plausible, r.observed_order >= 0.5 && r.observed_order <= 4);
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
