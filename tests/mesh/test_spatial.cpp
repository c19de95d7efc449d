#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "engine/mesh/generate.hpp"
#include "engine/spatial/octree.hpp"

using namespace palplab::mesh;
using namespace palplab::spatial;

namespace {

Positions random_points(int n, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  Positions V(n, 3);
  for (int i = 0; i < n; ++i) V.row(i) << u(rng), u(rng), 0.3 * u(rng);
  return V;
}

void expect_same_as_linear(const Octree& t, const Positions& V, std::mt19937_64& rng, int nq) {
  std::uniform_real_distribution<double> u(-0.15, 0.15);
  int mismatches = 0;
  for (int q = 0; q < nq; ++q) {
    Vec3 p(u(rng), u(rng), u(rng));
    double d_oct, d_lin;
    int a = nearest(t, V, p, &d_oct), b = linear_nearest(V, p, &d_lin);
    if (a != b || d_oct != d_lin) ++mismatches;
  }
  EXPECT_EQ(mismatches, 0);
}

}  // namespace

TEST(Octree, NearestEqualsLinearOnRandomQueries) {
  std::mt19937_64 rng(42);
  SurfaceMesh m = generate_tract({6000, 0});
  Octree t = build_octree(m.V, 10, 8);
  expect_same_as_linear(t, m.V, rng, 10000);
  Positions P = random_points(5000, rng);
  Octree tp = build_octree(P, 8, 4);
  expect_same_as_linear(tp, P, rng, 10000);
}

TEST(Octree, StaysExactAfterNodesMoveAndRefit) {
  std::mt19937_64 rng(7);
  SurfaceMesh m = generate_tract({1500, 0});
  Octree t = build_octree(m.V, 8, 6);
  Positions V = m.V;
  std::normal_distribution<double> n(0, 0.01);  // 1 cm displacements, many leave their octant
  for (int i = 0; i < V.rows(); ++i) V.row(i) += Eigen::RowVector3d(n(rng), n(rng), n(rng));
  refit(t, V);
  expect_same_as_linear(t, V, rng, 10000);
}

TEST(Octree, LeavesPartitionTheNodesAndRespectLimits) {
  std::mt19937_64 rng(3);
  Positions P = random_points(3000, rng);
  for (int depth : {0, 2, 5}) {
    Octree t = build_octree(P, depth, 16);
    std::vector<int> seen(P.rows(), 0);
    for (int n = 0; n < static_cast<int>(t.nodes.size()); ++n) {
      const OctreeNode& node = t.nodes[n];
      EXPECT_LE(node.depth, depth);
      if (!node.leaf) continue;
      if (node.depth < depth) {
        EXPECT_LE(node.end - node.begin, 16);
      }
      for (int p : leaf_points(t, n)) {
        ++seen[p];
        EXPECT_EQ(leaf_of(t, p), n);
        EXPECT_TRUE(node.cell.contains(P.row(p).transpose()));
      }
    }
    for (int s : seen) EXPECT_EQ(s, 1);
  }
  EXPECT_EQ(count_leaves(build_octree(P, 0, 1)), 1);
  EXPECT_THROW(build_octree(P, -1, 4), std::invalid_argument);
  EXPECT_THROW(build_octree(P, 4, 0), std::invalid_argument);
}

TEST(Octree, TiesResolveToSmallestIndexLikeLinear) {
  Positions V(4, 3);
  V << 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0;
  Octree t = build_octree(V, 4, 1);
  EXPECT_EQ(nearest(t, V, Vec3::Zero()), 0);
  EXPECT_EQ(linear_nearest(V, Vec3::Zero()), 0);
  Positions E(0, 3);
  EXPECT_EQ(nearest(build_octree(E, 4, 1), E, Vec3::Zero()), -1);
}

// Device glitches (issue 10): a NaN/inf query used to loop forever or read nodes[-1]; a +-1e300
// query overflowed every squared distance to inf.
TEST(Octree, NonFiniteQueryReturnsMinusOneAndHugeQueryStaysExact) {
  std::mt19937_64 rng(3);
  Positions P = random_points(3000, rng);
  Octree t = build_octree(P, 8, 4);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (Vec3 q : {Vec3(nan, 0, 0), Vec3(0, inf, 0), Vec3(0, 0, -inf), Vec3(nan, nan, nan)}) {
    double d2 = 0;
    EXPECT_EQ(nearest(t, P, q, &d2), -1);
    EXPECT_TRUE(std::isinf(d2));
    EXPECT_EQ(linear_nearest(P, q), -1);
  }
  Eigen::Index ixmax, ixmin, izmin;
  P.col(0).maxCoeff(&ixmax);
  P.col(0).minCoeff(&ixmin);
  P.col(2).minCoeff(&izmin);
  double d2 = 0;
  EXPECT_EQ(nearest(t, P, Vec3(1e300, 0, 0), &d2), ixmax);
  EXPECT_TRUE(std::isinf(d2));  // (1e300)^2 overflows; the index is still exact
  EXPECT_EQ(nearest(t, P, Vec3(-1e300, 0, 0)), ixmin);
  EXPECT_EQ(nearest(t, P, Vec3(0, 0, -1.7e308)), izmin);
  EXPECT_EQ(nearest(t, P, Vec3(1e300, 1e300, 0)), linear_nearest(P, Vec3(1e300, 1e300, 0)));
  // 1e150 is far but its squares are finite: the ordinary path. Every distance rounds to the
  // same double there (0.1 m is lost next to 1e150 m), so any node is right; it must be a node,
  // the one linear_nearest gives, with a finite distance.
  const int i150 = nearest(t, P, Vec3(1e150, 0, 0), &d2);
  EXPECT_EQ(i150, linear_nearest(P, Vec3(1e150, 0, 0)));
  EXPECT_GE(i150, 0);
  EXPECT_TRUE(std::isfinite(d2));
}
