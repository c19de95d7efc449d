// The surface grading of the FEM reference (refine_surface_near, fem_refine.hpp) and what it
// hands to TetGen: several rounds of grading split every coarse face into many coplanar children
// whose midpoints lie a few ulp off the face's plane. The self-intersection check in front of
// TetGen (check_tetgen_input) once reported such neighbours as crossing (a floating-point
// orientation of four nearly coplanar points has a random sign) and refused the 2-round graded
// surface of prototype D's body press; the check's predicates are now exact.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "engine/mesh/check.hpp"
#include "engine/mesh/tetrahedralize.hpp"
#include "engine/models/fem_block_mesh.hpp"
#include "engine/models/fem_refine.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {

// The closed boundary of a structured block, rotated by an angle whose coordinates are not
// dyadic (so midpoints of its faces' edges round off the faces' planes) and shifted.
mesh::SurfaceMesh rotated_box_surface(int n) {
  const mesh::TetMesh b = fem_block_mesh(n, n, n, Eigen::Vector3d(0.03, 0.03, 0.03), 101);
  const mesh::BoundaryFaces bf = mesh::boundary_faces(b);
  std::vector<int> map(static_cast<size_t>(b.V.rows()), -1);
  std::vector<Eigen::Vector3d> pts;
  mesh::Faces F(bf.F.rows(), 3);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  for (long f = 0; f < bf.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      int& v = map[static_cast<size_t>(bf.F(f, k))];
      if (v < 0) {
        v = static_cast<int>(pts.size());
        pts.push_back(R * mesh::row3(b.V, bf.F(f, k)) + Eigen::Vector3d(0.013, -0.021, 0.117));
      }
      F(f, k) = v;
    }
  mesh::Positions V(static_cast<long>(pts.size()), 3);
  for (size_t i = 0; i < pts.size(); ++i) V.row(static_cast<long>(i)) = pts[i].transpose();
  return mesh::make_surface_mesh(V, F);
}

}  // namespace

// Three rounds over the whole box: every face of the rotated box becomes up to 64 children,
// coplanar up to round-off. The result is the same polyhedron, so it has no self-intersection,
// and TetGen meshes it.
TEST(FemGrading, GradedSurfaceHasNoSpuriousSelfIntersections) {
  const mesh::SurfaceMesh s = rotated_box_surface(3);
  const Eigen::Vector3d centre = s.V.colwise().mean().transpose();
  const mesh::SurfaceMesh g = refine_surface_near(s, centre, 0.05, 3);
  ASSERT_GT(g.F.rows(), 30 * s.F.rows());  // most faces split three times
  mesh::CheckOptions co;
  co.max_per_kind = 5;
  const mesh::CheckReport rep = mesh::check_surface(g, co);
  EXPECT_EQ(rep.counts.count("self_intersection"), 0u)
      << rep.counts.at("self_intersection") << " spurious self-intersections";
  EXPECT_NO_THROW(mesh::check_tetgen_input(g));
  mesh::TetOptions to;
  to.quality = 2.0;
  const mesh::TetMesh m = mesh::tetrahedralize(g, to);
  EXPECT_GT(m.T.rows(), g.F.rows() / 2);
  EXPECT_NEAR(m.volume.sum(), 0.03 * 0.03 * 0.03, 1e-12);
}

// The exact predicates still find real crossings among nearly coplanar faces: a copy of one
// graded face lifted by 1e-9 m (well above round-off) and tilted through its neighbours.
TEST(FemGrading, CheckStillFindsACrossingNearCoplanarFaces) {
  const mesh::SurfaceMesh s = rotated_box_surface(2);
  const Eigen::Vector3d centre = s.V.colwise().mean().transpose();
  mesh::SurfaceMesh g = refine_surface_near(s, centre, 0.05, 2);
  // A triangle through the plane of face 0: one corner 1 um above, two 1 um below, over it.
  const Eigen::Vector3d a = mesh::row3(g.V, g.F(0, 0)), b = mesh::row3(g.V, g.F(0, 1)),
                        c = mesh::row3(g.V, g.F(0, 2));
  const Eigen::Vector3d n = (b - a).cross(c - a).normalized(), m = (a + b + c) / 3;
  mesh::Positions V(g.V.rows() + 3, 3);
  V.topRows(g.V.rows()) = g.V;
  V.row(g.V.rows()) = (m + 2 * (a - m) + 1e-6 * n).transpose();
  V.row(g.V.rows() + 1) = (m + 2 * (b - m) - 1e-6 * n).transpose();
  V.row(g.V.rows() + 2) = (m + 2 * (c - m) - 1e-6 * n).transpose();
  mesh::Faces F(g.F.rows() + 1, 3);
  F.topRows(g.F.rows()) = g.F;
  const int v0 = static_cast<int>(g.V.rows());
  F.row(g.F.rows()) << v0, v0 + 1, v0 + 2;
  const std::vector<std::pair<int, int>> x = mesh::self_intersections(V, F);
  EXPECT_FALSE(x.empty());
  for (auto [f, h] : x) EXPECT_TRUE(f == g.F.rows() || h == g.F.rows()) << f << " " << h;
}
