#include <gtest/gtest.h>

#include "common/input_error.hpp"
#include "engine/mesh/surface_mesh.hpp"
#include "engine/mesh/tet_mesh.hpp"
#include "fixtures.hpp"

using namespace palplab::mesh;
using namespace palplab::mesh::testing;

TEST(TetMesh, VolumesAndVertexMap) {
  TetMesh m = kuhn_grid(3, [](double, double, double) { return 101; });
  EXPECT_EQ(m.T.rows(), 162);
  for (int t = 0; t < m.T.rows(); ++t) {
    EXPECT_GT(signed_volume(m.V, m.T, t), 0);
    EXPECT_NEAR(m.volume[t], 1.0 / (6 * 27), 1e-15);
  }
  EXPECT_NEAR(m.volume.sum(), 1.0, 1e-13);
  for (int v = 0; v < m.V.rows(); ++v)
    for (int t : m.vertex_tets.row(v)) {
      EXPECT_TRUE((m.T.row(t).array() == v).any());
    }
  EXPECT_EQ(static_cast<long>(m.vertex_tets.index.size()), 4 * m.T.rows());
}

TEST(TetMesh, SpecVolumeFormulaOnUnitTet) {
  Positions V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  Tets T(1, 4);
  T << 0, 1, 2, 3;
  TetMesh m = make_tet_mesh(V, T);
  EXPECT_NEAR(m.volume[0], 1.0 / 6.0, 1e-16);
  EXPECT_NEAR(signed_volume(V, T, 0), 1.0 / 6.0, 1e-16);
  // Regular tet has radius ratio 1; a flattened one tends to 0.
  Vec3 a(1, 1, 1), b(1, -1, -1), c(-1, 1, -1), d(-1, -1, 1);
  EXPECT_NEAR(radius_ratio(a, b, c, d), 1.0, 1e-12);
  EXPECT_LT(radius_ratio(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0.5, 0.5, 1e-4)), 0.01);
  T << 0, 1, 2, 7;
  EXPECT_THROW(make_tet_mesh(V, T), palplab::InputError);
}

TEST(TetMesh, BoundaryFacesLinearEqualsBruteForce) {
  for (int n : {1, 2, 3}) {
    TetMesh m = kuhn_grid(
        n, [](double x, double, double z) { return x < 0.5 ? 101 : (z < 0.5 ? 200 : 300); });
    for (int mode = 0; mode < 4; ++mode) {
      BoundaryOptions o;
      o.tissue_interfaces = mode >= 1;
      o.skip_towards_rigid = mode >= 2;
      o.skip_rigid_outer = mode == 3;
      BoundaryFaces a = boundary_faces(m, o), b = boundary_faces_brute_force(m, o);
      EXPECT_EQ(a.F, b.F) << n << " " << mode;
      EXPECT_EQ(a.tet, b.tet);
      EXPECT_EQ(a.local, b.local);
      if (mode == 0) {
        EXPECT_EQ(a.F.rows(), 12 * n * n);  // 6 sides, 2 triangles per square
      }
    }
  }
}

TEST(TetMesh, OuterBoundaryIsClosedOutwardAndEnclosesTheVolume) {
  TetMesh m = kuhn_grid(3, [](double, double, double) { return 101; });
  BoundaryFaces b = boundary_faces(m);
  SurfaceMesh s = make_surface_mesh(m.V, b.F);
  EXPECT_TRUE(is_closed_manifold(s));
  EXPECT_NEAR(enclosed_volume(m.V, b.F), m.volume.sum(), 1e-12);
  Tets N = tet_neighbours(m);
  int outer = 0;
  for (int t = 0; t < N.rows(); ++t)
    for (int k = 0; k < 4; ++k) {
      if (N(t, k) < 0) {
        ++outer;
        continue;
      }
      const int s2 = N(t, k);
      EXPECT_TRUE((N.row(s2).array() == t).any());
    }
  EXPECT_EQ(outer, b.F.rows());
}

TEST(TetMesh, RigidFacesAreSkippedOnRequest) {
  // Left half soft tissue (101), right half bone (200).
  TetMesh m = kuhn_grid(2, [](double x, double, double) { return x < 0.5 ? 101 : 200; });
  BoundaryOptions o;
  o.tissue_interfaces = true;
  const int with = static_cast<int>(boundary_faces(m, o).F.rows());
  o.skip_towards_rigid = true;
  const int without = static_cast<int>(boundary_faces(m, o).F.rows());
  EXPECT_EQ(with - without, 8);  // the 2x2 interface squares at x = 0.5
  o.skip_rigid_outer = true;
  BoundaryFaces soft = boundary_faces(m, o);
  for (int i = 0; i < soft.tet.size(); ++i) EXPECT_EQ(m.attribute[soft.tet[i]], 101);
  // Soft half x < 0.5: the x = 0 side (8 triangles) and half of the four sides around (4 x 4).
  EXPECT_EQ(soft.F.rows(), 24);
}

// The one scan behind `mesh check`'s duplicate_tet/unused_vertex and the models' refusal.
TEST(TetMesh, ConnectivityFindsRepeatedNodesDuplicatesAndUnusedVertices) {
  const TetMesh clean = kuhn_grid(2, [](double, double, double) { return 101; });
  const TetConnectivity none = tet_connectivity(clean.T, clean.V.rows());
  EXPECT_TRUE(none.repeated_node.empty());
  EXPECT_TRUE(none.duplicate_tet.empty());
  EXPECT_TRUE(none.unused_vertex.empty());

  Tets T(5, 4);
  T << 0, 1, 2, 3,                                   //
      3, 2, 1, 0,                                    // tet 0's nodes in another order: a duplicate
      1, 2, 3, 4,                                    //
      1, 1, 2, 3,                                    // a node twice
      4, 3, 2, 1;                                    // tet 2 again
  const TetConnectivity c = tet_connectivity(T, 7);  // nodes 5 and 6 unused
  EXPECT_EQ(c.repeated_node, std::vector<int>{3});
  ASSERT_EQ(c.duplicate_tet.size(), 2u);
  EXPECT_EQ(c.duplicate_tet[0], std::make_pair(0, 1));
  EXPECT_EQ(c.duplicate_tet[1], std::make_pair(2, 4));
  EXPECT_EQ(c.unused_vertex, (std::vector<int>{5, 6}));
}
