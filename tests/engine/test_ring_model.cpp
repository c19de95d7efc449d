// Prototype B's ring model: displacement pattern of Eq 4.2–4.4, every node back at rest
// after release through the home springs (Eq 4.11), in every scope mode; octree touched-node
// search equals the linear search.
#include <gtest/gtest.h>

#include <random>

#include "engine/mesh/generate.hpp"
#include "engine/models/ring_model.hpp"

using namespace palplab;
using namespace palplab::engine;

TEST(RingModel, PressDisplacesRingsDeepestAtTouchedNode) {
  const mesh::SurfaceMesh s = mesh::generate_sphere(642);
  RingParams p;
  RingModel m = make_ring_model(s.V, s.E, p);
  const Eigen::Vector3d push(0, 0, -2.0);  // 2 N into the sphere
  const int node = 17;
  ring_step(m, node, push, 1e-3);
  EXPECT_NEAR((m.X.row(node) - m.X_fixed.row(node)).norm(), p.m1 * 2.0, 1e-15);
  for (int q : m.rings->first.row(node))
    EXPECT_NEAR((m.X.row(q) - m.X_fixed.row(q)).norm(), p.m2 * 2.0, 1e-15);
  for (int r : m.rings->second.row(node))
    EXPECT_NEAR((m.X.row(r) - m.X_fixed.row(r)).norm(), p.m3 * 2.0, 1e-15);
  // Displacement is along the push.
  const Eigen::Vector3d d = (m.X.row(node) - m.X_fixed.row(node)).transpose();
  EXPECT_NEAR(d.normalized().dot(push.normalized()), 1.0, 1e-12);
  // Nothing else moved.
  long moved = 0;
  for (long i = 0; i < m.X.rows(); ++i) moved += (m.X.row(i) - m.X_fixed.row(i)).norm() > 0;
  EXPECT_EQ(moved, 1 + static_cast<long>(m.rings->first.row(node).size() +
                                         m.rings->second.row(node).size()));
}

TEST(RingModel, EveryNodeReturnsToRestAfterReleaseInEveryScope) {
  const mesh::SurfaceMesh s = mesh::generate_sphere(642);
  const spatial::Octree tree = spatial::build_octree(s.V, 10, 8);
  for (Scope scope : {Scope::rings, Scope::octant, Scope::whole}) {
    RingModel m = make_ring_model(s.V, s.E, RingParams{});
    m.scope = scope;
    m.octree = &tree;
    // Slide the press over several nodes (as an exploring hand would), then release.
    for (int k = 0; k < 300; ++k)
      ring_step(m, (k / 50) * 37 % 642, Eigen::Vector3d(0.3, -1.0, 0.5), 1e-3);
    EXPECT_GT(ring_max_displacement(m), 1e-3);
    double max_disp = 0.0;
    for (int k = 0; k < 2000; ++k) {
      ring_step(m, -1, Eigen::Vector3d::Zero(), 1e-3);
      max_disp = std::max(max_disp, ring_max_displacement(m));
    }
    EXPECT_LT(max_disp, 0.0061) << "home springs must not overshoot beyond the press";
    EXPECT_EQ(ring_max_displacement(m), 0.0) << to_string(scope);  // exactly home
    EXPECT_EQ(m.V.norm(), 0.0);
    if (scope == Scope::rings) {
      EXPECT_TRUE(m.active.empty());
    }
  }
}

TEST(RingModel, OctreeTouchedNodeEqualsLinearSearch) {
  const mesh::SurfaceMesh s = mesh::generate_tract({6000, 0});
  const spatial::Octree tree = spatial::build_octree(s.V, 12, 8);
  std::mt19937 rng(3);
  const Eigen::Vector3d lo = s.V.colwise().minCoeff().transpose(),
                        hi = s.V.colwise().maxCoeff().transpose();
  std::uniform_real_distribution<double> U(0, 1);
  for (int k = 0; k < 2000; ++k) {
    Eigen::Vector3d q;
    for (int a = 0; a < 3; ++a) q[a] = lo[a] - 0.02 + (hi[a] - lo[a] + 0.04) * U(rng);
    // Half the queries near the surface (where a hand touches).
    if (k % 2)
      q = s.V.row(k % s.V.rows()).transpose() + 0.002 * Eigen::Vector3d(U(rng), U(rng), U(rng));
    ASSERT_EQ(spatial::nearest(tree, s.V, q), spatial::linear_nearest(s.V, q)) << k;
  }
}
