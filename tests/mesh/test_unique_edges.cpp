// mesh::unique_edges, the one edge extraction: exact edge sets of small meshes, Euler's formula on
// closed surfaces, and agreement with the half-edge connectivity's edges.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <set>
#include <utility>

#include "engine/mesh/unique_edges.hpp"
#include "fixtures.hpp"

using namespace palplab::mesh;

namespace {

// Edge set by brute force: every vertex pair of every element, as a std::set.
template <typename Elements>
std::set<std::pair<int, int>> pairs_of(const Elements& S) {
  std::set<std::pair<int, int>> e;
  for (long s = 0; s < S.rows(); ++s)
    for (int i = 0; i < S.cols(); ++i)
      for (int j = i + 1; j < S.cols(); ++j)
        e.insert({std::min(S(s, i), S(s, j)), std::max(S(s, i), S(s, j))});
  return e;
}

// E as a set, checking that its rows are ordered pairs, strictly ascending.
std::set<std::pair<int, int>> rows_of(const Edges& E) {
  std::set<std::pair<int, int>> e;
  for (long k = 0; k < E.rows(); ++k) {
    EXPECT_LT(E(k, 0), E(k, 1)) << k;
    if (k > 0) {
      EXPECT_TRUE(std::make_pair(E(k - 1, 0), E(k - 1, 1)) < std::make_pair(E(k, 0), E(k, 1)));
    }
    e.insert({E(k, 0), E(k, 1)});
  }
  return e;
}

}  // namespace

TEST(UniqueEdges, OneTetHasSixEdgesInOrder) {
  Tets T(1, 4);
  T << 3, 1, 0, 2;  // any vertex order
  const Edges E = unique_edges(T);
  ASSERT_EQ(E.rows(), 6);
  Edges expect(6, 2);
  expect << 0, 1, 0, 2, 0, 3, 1, 2, 1, 3, 2, 3;
  EXPECT_EQ(E, expect);
}

TEST(UniqueEdges, TwoTrianglesShareOneEdge) {
  Faces F(2, 3);
  F << 0, 1, 2, 2, 1, 3;
  const Edges E = unique_edges(F);
  Edges expect(5, 2);
  expect << 0, 1, 0, 2, 1, 2, 1, 3, 2, 3;
  EXPECT_EQ(E, expect);
  EXPECT_EQ(unique_edges(Faces(0, 3)).rows(), 0);
}

TEST(UniqueEdges, ClosedSurfaceSatisfiesEulerAndMatchesHalfEdges) {
  const SurfaceMesh m = palplab::mesh::testing::cube();
  const Edges E = unique_edges(m.F);
  // V - E + F = 2 for a closed genus-0 surface: 8 - 18 + 12.
  EXPECT_EQ(E.rows(), 18);
  EXPECT_EQ(m.V.rows() - E.rows() + m.F.rows(), 2);
  // The half-edge connectivity's edge list is the same set in the same order.
  EXPECT_EQ(E, m.E);
  const SurfaceMesh g = palplab::mesh::testing::grid(7, 5);
  EXPECT_EQ(unique_edges(g.F), g.E);
  EXPECT_EQ(rows_of(unique_edges(g.F)), pairs_of(g.F));
}

TEST(UniqueEdges, TetMeshEdgesAreEveryPairOnce) {
  const TetMesh tm = palplab::mesh::testing::kuhn_grid(3, [](double, double, double) { return 0; });
  const Edges E = unique_edges(tm.T);
  const auto brute = pairs_of(tm.T);
  EXPECT_EQ(static_cast<size_t>(E.rows()), brute.size());
  EXPECT_EQ(rows_of(E), brute);
  // Euler characteristic of a ball: V - E + F - T = 1 (F from the tets' faces).
  std::set<std::array<int, 3>> faces;
  for (long t = 0; t < tm.T.rows(); ++t)
    for (int skip = 0; skip < 4; ++skip) {
      std::array<int, 3> f{};
      for (int i = 0, k = 0; i < 4; ++i)
        if (i != skip) f[k++] = tm.T(t, i);
      std::sort(f.begin(), f.end());
      faces.insert(f);
    }
  EXPECT_EQ(tm.V.rows() - E.rows() + static_cast<long>(faces.size()) - tm.T.rows(), 1);
}
