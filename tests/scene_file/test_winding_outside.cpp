// ContactTracker::winding_number's shortcut outside the bounding box of a closed, consistently
// oriented surface (0 exactly, without the sum over the faces; the first step of every scene, so
// of every .psim load, takes it) against the sum of the faces' solid angles, and the surfaces
// that must not take it: open, with a flipped face, with a duplicated face.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

#include "engine/haptics/contact.hpp"
#include "tests/octahedron.hpp"

namespace {

using namespace palplab;
using Vec3 = Eigen::Vector3d;

// The octahedron |x| + |y| + |z| = 1, faces ccw seen from outside.
using Octa = palplab::test::Octahedron;

// Reference: the signed solid angles of the faces (Van Oosterom & Strackee) over 4 pi.
double solid_angle_sum(const mesh::Positions& V, const mesh::Faces& F, const Vec3& x) {
  double omega = 0.0;
  for (long f = 0; f < F.rows(); ++f) {
    const Vec3 a = V.row(F(f, 0)).transpose() - x, b = V.row(F(f, 1)).transpose() - x,
               c = V.row(F(f, 2)).transpose() - x;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    omega += 2.0 * std::atan2(a.dot(b.cross(c)),
                              la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb);
  }
  return omega / (4.0 * M_PI);
}

double winding(const mesh::Positions& V, const mesh::Faces& F, const Vec3& x) {
  const engine::ContactTracker t(V, V, F);  // normals unused by the inside test
  return t.winding_number(x);
}

const Vec3 kOutside[] = {{5, -3, 2}, {1.5, 0, 0}, {0, -1.0 - 1e-9, 0}, {0.2, 0.1, 1.01}};

TEST(WindingOutside, ClosedSurfaceOutsideItsBoxIsZeroExactly) {
  const Octa o;
  for (const Vec3& x : kOutside) {
    EXPECT_EQ(winding(o.V, o.F, x), 0.0) << x.transpose();
    EXPECT_NEAR(solid_angle_sum(o.V, o.F, x), 0.0, 1e-12) << x.transpose();
  }
  // Inside the box the faces are summed: inside the surface 1, between it and the box 0.
  EXPECT_NEAR(winding(o.V, o.F, {0.1, 0.2, -0.1}), 1.0, 1e-12);
  EXPECT_NEAR(winding(o.V, o.F, {0.9, 0.9, 0.0}), 0.0, 1e-12);
  EXPECT_NEAR(winding(o.V, o.F, {0.9, 0.9, 0.0}), solid_angle_sum(o.V, o.F, {0.9, 0.9, 0.0}),
              1e-15);
}

// A surface whose winding number outside the box is not 0 must be summed, not cut short: the
// value is then the reference's, and visibly not 0 from a point facing the defect.
void expect_summed(const mesh::Positions& V, const mesh::Faces& F, const Vec3& facing) {
  for (const Vec3& x : kOutside) {
    const double ref = solid_angle_sum(V, F, x);
    EXPECT_NEAR(winding(V, F, x), ref, 1e-14) << x.transpose();
  }
  const double ref = solid_angle_sum(V, F, facing);
  EXPECT_GT(std::abs(ref), 0.01);  // 0.044 from (1, 1, 1)
  EXPECT_NEAR(winding(V, F, facing), ref, 1e-14);
}

// The first face, (+x, +y, +z), faces the point (1, 1, 1).
const Vec3 kFacingFace0(1, 1, 1);

TEST(WindingOutside, OpenSurfaceIsSummed) {
  const Octa o;
  const mesh::Faces F = o.F.bottomRows(7);  // face 0 removed: a hole
  expect_summed(o.V, F, kFacingFace0);
}

TEST(WindingOutside, FlippedFaceIsSummed) {
  Octa o;
  std::swap(o.F(0, 1), o.F(0, 2));
  expect_summed(o.V, o.F, kFacingFace0);
}

TEST(WindingOutside, DuplicatedFaceIsSummed) {
  const Octa o;
  mesh::Faces F(9, 3);
  F << o.F, o.F.row(0);
  expect_summed(o.V, F, kFacingFace0);
}

}  // namespace
