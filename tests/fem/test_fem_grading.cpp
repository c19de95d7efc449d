// The surface grading of the FEM reference (refine_surface_near, fem_refine.hpp) and what it
// hands to TetGen: several rounds of grading split every coarse face into many coplanar children
// whose midpoints lie a few ulp off the face's plane. The self-intersection check in front of
// TetGen (check_tetgen_input) once reported such neighbours as crossing (a floating-point
// orientation of four nearly coplanar points has a random sign) and refused the 2-round graded
// surface of prototype D's body press; the check's predicates are now exact.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "common/input_error.hpp"
#include "engine/mesh/check.hpp"
#include "engine/mesh/tetrahedralize.hpp"
#include "engine/models/fem_block_mesh.hpp"
#include "engine/models/fem_reference.hpp"
#include "engine/models/fem_refine.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {

// The closed boundary of a structured block, rotated by an angle whose coordinates are not
// dyadic (so midpoints of its faces' edges round off the faces' planes) and shifted.
mesh::SurfaceMesh rotated_box_surface(int n, bool rotate = true) {
  const mesh::TetMesh b = fem_block_mesh(n, n, n, Eigen::Vector3d(0.03, 0.03, 0.03), 101);
  const mesh::BoundaryFaces bf = mesh::boundary_faces(b);
  std::vector<int> map(static_cast<size_t>(b.V.rows()), -1);
  std::vector<Eigen::Vector3d> pts;
  mesh::Faces F(bf.F.rows(), 3);
  const Eigen::Matrix3d R =
      rotate ? Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix()
             : Eigen::Matrix3d::Identity();
  for (long f = 0; f < bf.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      int& v = map[static_cast<size_t>(bf.F(f, k))];
      if (v < 0) {
        v = static_cast<int>(pts.size());
        pts.push_back(R * mesh::row3(b.V, bf.F(f, k)) +
                      (rotate ? Eigen::Vector3d(0.013, -0.021, 0.117) : Eigen::Vector3d::Zero()));
      }
      F(f, k) = v;
    }
  mesh::Positions V(static_cast<long>(pts.size()), 3);
  for (size_t i = 0; i < pts.size(); ++i) V.row(static_cast<long>(i)) = pts[i].transpose();
  return mesh::make_surface_mesh(V, F);
}

}  // namespace

// Three rounds over the whole box: every face of the rotated box becomes up to 64 children
// coplanar up to round-off. The result is the same polyhedron, so it has no self-intersection,
// and TetGen meshes it. (With the former floating-point orientations the check reported 4
// crossings on this surface, 7 after two rounds, 8 on the 3x3x3 block after three.)
TEST(FemGrading, GradedSurfaceHasNoSpuriousSelfIntersections) {
  const mesh::SurfaceMesh s = rotated_box_surface(2);
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

// The PCG solve of static reference levels (pcg_min_dofs) gives the direct solve's stiffness on
// every level, and starts the nested levels from the prolongated coarser solution.
TEST(FemGrading, PcgLevelsMatchTheFactorisation) {
  FemReferenceOptions o;
  o.surface = rotated_box_surface(2, false);  // 3 cm cube, base pinned, pressed on top
  o.is_fixed = [](const Eigen::Vector3d& p) { return p.z() < 1e-9; };
  o.press_point = Eigen::Vector3d(0.015, 0.015, 0.03);
  o.press_direction = -Eigen::Vector3d::UnitZ();
  o.force = 0.5;
  o.press_radius = 0.01;
  o.max_volume = 8e-7;
  o.levels = 3;
  o.refinement = FemRefinement::nested;
  o.solver = SparseSolverKind::ldlt;
  const FemReferenceResult direct = fem_reference(o);
  o.pcg_min_dofs = 1;
  o.pcg_tolerance = 1e-12;
  const FemReferenceResult pcg = fem_reference(o);
  ASSERT_EQ(pcg.levels.size(), 3u);
  for (size_t l = 0; l < 3; ++l) {
    EXPECT_EQ(direct.levels[l].solver, "ldlt");
    // The coarser levels are factorised: the finest level's coarse correction.
    EXPECT_EQ(pcg.levels[l].solver, l < 2 ? "ldlt" : "pcg-two-level");
    if (l == 2) {
      EXPECT_GT(pcg.levels[l].pcg_iterations, 0);
    }
    EXPECT_EQ(pcg.levels[l].tets, direct.levels[l].tets);
    EXPECT_EQ(pcg.levels[l].dofs, direct.levels[l].dofs);
    EXPECT_NEAR(pcg.levels[l].stiffness, direct.levels[l].stiffness,
                1e-8 * direct.levels[l].stiffness)
        << l;
  }
  EXPECT_GT(direct.levels[2].tets, 4000);
  EXPECT_NEAR(pcg.stiffness, direct.stiffness, 1e-6 * direct.stiffness);
  // A static-only option: with the quasi-static curve it is an input error.
  o.curve_steps = 2;
  EXPECT_THROW(fem_reference(o), InputError);
}

// --grade auto (fem_reference_auto_grade) checks its inputs; its behaviour (more rounds until the
// reference is trusted) is tested end to end on the 400-vertex D's body press
// (tests/cli_fem CliFemD.AutoGradingEndsWithATrustedBodyReference). On this file's 4x4x2 block
// it was measured (not a test: 50 s of CPU): 1 round (the resolution rule) 11.6 %, 2 rounds
// 7.0 %, 3 rounds 3.2 % (trusted, 221k tets on the finest level).
TEST(FemGrading, AutoGradingChecksItsOptions) {
  FemReferenceOptions o;
  o.surface = rotated_box_surface(2, false);
  o.is_fixed = [](const Eigen::Vector3d& p) { return p.z() < 1e-9; };
  o.press_point = Eigen::Vector3d(0.015, 0.015, 0.03);
  o.max_volume = 8e-7;
  o.refinement = FemRefinement::nested;
  EXPECT_THROW(fem_reference_auto_grade(o, 7), InputError);
  EXPECT_THROW(fem_reference_auto_grade(o, -1), InputError);
  EXPECT_THROW(fem_reference_auto_grade(o, 6, 0.0), InputError);
  o.refinement = FemRefinement::tetgen;
  EXPECT_THROW(fem_reference_auto_grade(o, 6), InputError);
}
