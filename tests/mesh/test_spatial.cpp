#include <gtest/gtest.h>

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
