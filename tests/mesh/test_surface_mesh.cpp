#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "common/input_error.hpp"
#include "engine/mesh/generate.hpp"
#include "engine/mesh/rings.hpp"
#include "fixtures.hpp"

using namespace palplab::mesh;
using namespace palplab::mesh::testing;

namespace {

// Invariants every half-edge structure must satisfy.
void expect_half_edge_invariants(const SurfaceMesh& m) {
  const int nh = 3 * static_cast<int>(m.F.rows());
  for (int h = 0; h < nh; ++h) {
    EXPECT_EQ(he_next(he_next(he_next(h))), h);
    EXPECT_EQ(he_prev(he_next(h)), h);
    EXPECT_EQ(he_target(m, h), he_origin(m, he_next(h)));
    const int t = m.twin[h];
    if (t >= 0) {
      EXPECT_EQ(m.twin[t], h);
      EXPECT_EQ(he_origin(m, t), he_target(m, h));
      EXPECT_EQ(he_target(m, t), he_origin(m, h));
      EXPECT_EQ(m.he_edge[t], m.he_edge[h]);
    } else {
      EXPECT_EQ(m.edge_faces[m.he_edge[h]], 1);  // the meshes tested here are manifold
    }
    const int e = m.he_edge[h];
    const int a = he_origin(m, h), b = he_target(m, h);
    EXPECT_EQ(m.E(e, 0), std::min(a, b));
    EXPECT_EQ(m.E(e, 1), std::max(a, b));
  }
  for (int v = 0; v < m.V.rows(); ++v)
    if (m.vertex_he[v] >= 0) {
      EXPECT_EQ(he_origin(m, m.vertex_he[v]), v);
    }
  // The one-ring from the rotation equals the neighbours through the edge list.
  RingTable r = compute_rings(static_cast<int>(m.V.rows()), m.E);
  std::vector<int> ring;
  for (int v = 0; v < m.V.rows(); ++v) {
    one_ring(m, v, ring);
    std::vector<int> sorted = ring;
    std::sort(sorted.begin(), sorted.end());
    auto row = r.first.row(v);
    EXPECT_EQ(sorted, std::vector<int>(row.begin(), row.end())) << "vertex " << v;
  }
}

}  // namespace

TEST(SurfaceMesh, GridHalfEdges) {
  SurfaceMesh m = grid(4, 4);
  EXPECT_EQ(m.F.rows(), 18);
  EXPECT_EQ(m.E.rows(), 33);  // 12 horizontal + 12 vertical + 9 diagonal
  expect_half_edge_invariants(m);
  EXPECT_EQ(euler_characteristic(m), 1);  // a disc
  EXPECT_EQ(count_boundary_edges(m), 12);
  auto loops = boundary_loops(m);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_EQ(loops[0].size(), 12u);
  EXPECT_EQ(genus(m), -1);  // has a boundary
  EXPECT_TRUE(is_boundary_vertex(m, 0));
  EXPECT_FALSE(is_boundary_vertex(m, 5));
  std::vector<int> ring;
  one_ring(m, 5, ring);  // fan order, counter-clockwise seen from +z
  ASSERT_EQ(ring.size(), 6u);
  // Counter-clockwise order around 5 = (1,1): 6 (1,0)dir, 10, 9, 4, 0, 1 — check cyclic order.
  const std::vector<int> ccw = {6, 10, 9, 4, 0, 1};
  auto it = std::find(ring.begin(), ring.end(), 6);
  std::rotate(ring.begin(), it, ring.end());
  EXPECT_EQ(ring, ccw);
  one_ring(m, 0, ring);  // corner: 1, 5, 4 in fan order
  EXPECT_EQ(ring, (std::vector<int>{1, 5, 4}));
}

TEST(SurfaceMesh, CubeIsClosedGenusZero) {
  SurfaceMesh m = cube();
  expect_half_edge_invariants(m);
  EXPECT_EQ(m.E.rows(), 18);
  EXPECT_EQ(euler_characteristic(m), 2);
  EXPECT_TRUE(is_closed_manifold(m));
  EXPECT_EQ(genus(m), 0);
  EXPECT_TRUE(boundary_loops(m).empty());
  EXPECT_NEAR(enclosed_volume(m.V, m.F), 1.0, 1e-15);
  Positions N = vertex_normals(m.V, m.F);
  // Corner 7 = (1,1,1): the normal points along (1,1,1).
  EXPECT_GT(N.row(7).dot(Eigen::RowVector3d(1, 1, 1).normalized()), 0.9);
  EXPECT_NEAR(face_areas(m.V, m.F).sum(), 6.0, 1e-14);
}

TEST(SurfaceMesh, FlippedFaceIsInconsistentButOrientable) {
  SurfaceMesh c = cube();
  Faces F = c.F;
  std::swap(F(0, 1), F(0, 2));
  SurfaceMesh m = make_surface_mesh(c.V, F);
  EXPECT_EQ(m.inconsistent_edges.size(), 3u);
  EXPECT_TRUE(is_orientable(m));
  EXPECT_FALSE(is_closed_manifold(m));
}

TEST(SurfaceMesh, TorusHasGenusOne) {
  // 6 x 4 torus grid.
  const int a = 6, b = 4;
  Positions V(a * b, 3);
  for (int i = 0; i < a; ++i)
    for (int j = 0; j < b; ++j) {
      double u = 2 * M_PI * i / a, v = 2 * M_PI * j / b;
      V.row(i * b + j) << (2 + std::cos(v)) * std::cos(u), (2 + std::cos(v)) * std::sin(u),
          std::sin(v);
    }
  Faces F(2 * a * b, 3);
  int f = 0;
  for (int i = 0; i < a; ++i)
    for (int j = 0; j < b; ++j) {
      int p = i * b + j, q = ((i + 1) % a) * b + j, r = ((i + 1) % a) * b + (j + 1) % b,
          s = i * b + (j + 1) % b;
      F.row(f++) << p, q, r;
      F.row(f++) << p, r, s;
    }
  SurfaceMesh m = make_surface_mesh(V, F);
  expect_half_edge_invariants(m);
  EXPECT_EQ(euler_characteristic(m), 0);
  EXPECT_EQ(genus(m), 1);
}

TEST(SurfaceMesh, BadIndexIsInputError) {
  Positions V = Positions::Zero(3, 3);
  Faces F(1, 3);
  F << 0, 1, 3;
  EXPECT_THROW(make_surface_mesh(V, F), palplab::InputError);
}

TEST(Rings, HandCheckedGridPatch) {
  SurfaceMesh m = grid(4, 4);
  RingTable r = compute_rings(16, m.E);
  auto vec = [](std::span<const int> s) { return std::vector<int>(s.begin(), s.end()); };
  // Worked out by hand on the 4x4 grid (see fixtures.hpp for the diagonals).
  EXPECT_EQ(vec(r.first.row(5)), (std::vector<int>{0, 1, 4, 6, 9, 10}));
  EXPECT_EQ(vec(r.second.row(5)), (std::vector<int>{2, 7, 8, 11, 13, 14, 15}));
  EXPECT_EQ(vec(r.first.row(0)), (std::vector<int>{1, 4, 5}));
  EXPECT_EQ(vec(r.second.row(0)), (std::vector<int>{2, 6, 8, 9, 10}));
  EXPECT_EQ(vec(r.first.row(15)), (std::vector<int>{10, 11, 14}));
  EXPECT_EQ(vec(r.second.row(15)), (std::vector<int>{5, 6, 7, 9, 13}));
  EXPECT_EQ(r.first.rows(), 16);
  EXPECT_EQ(r.second.rows(), 16);
}

TEST(Generate, TractModelsAreClosedGenusZeroWithinSizes) {
  for (int target : {1500, 6000}) {
    SurfaceMesh m = generate_tract({target, 0});
    EXPECT_NEAR(m.V.rows(), target, 0.02 * target);
    EXPECT_NEAR(m.F.rows(), 2 * target, 0.02 * 2 * target);
    expect_half_edge_invariants(m);
    EXPECT_EQ(euler_characteristic(m), 2);
    EXPECT_EQ(genus(m), 0);
    EXPECT_TRUE(is_closed_manifold(m));
    EXPECT_GT(enclosed_volume(m.V, m.F), 0);  // outward orientation
    const Eigen::RowVector3d size = m.V.colwise().maxCoeff() - m.V.colwise().minCoeff();
    EXPECT_NEAR(size.x(), 0.145, 0.1 * 0.145);  // across the horns
    // The body is 5 cm wide; the horns curl forwards (+y) beyond it.
    Eigen::RowVector3d blo = Eigen::RowVector3d::Constant(1e9), bhi = -blo;
    for (int v = 0; v < m.V.rows(); ++v)
      if (m.V(v, 2) < 0.19) {
        blo = blo.cwiseMin(m.V.row(v));
        bhi = bhi.cwiseMax(m.V.row(v));
      }
    EXPECT_NEAR(bhi.x() - blo.x(), 0.05, 0.1 * 0.05);  // body width
    EXPECT_NEAR(bhi.y() - blo.y(), 0.05, 0.1 * 0.05);
    EXPECT_LT(size.y(), 0.12);
    EXPECT_NEAR(size.z(), 0.355, 0.1 * 0.355);  // length
    // Every named region is present.
    ASSERT_EQ(m.regions.names, tract_region_names());
    for (int r = 0; r < 6; ++r) EXPECT_GT((m.regions.id.array() == r).count(), 10) << r;
    // Ovaries near the horn tips: left ovary on -x, right on +x, above the body.
    Eigen::VectorXi vr = vertex_regions(m);
    for (int v = 0; v < m.V.rows(); ++v) {
      if (vr[v] == 0) {
        EXPECT_LT(m.V(v, 0), -0.02);
      }
      if (vr[v] == 1) {
        EXPECT_GT(m.V(v, 0), 0.02);
      }
      if (vr[v] <= 1) {
        EXPECT_GT(m.V(v, 2), 0.2);
      }
    }
  }
}

TEST(Generate, SeedsPerturbWithinTenPercent) {
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    SurfaceMesh m = generate_tract({1500, seed});
    const Eigen::RowVector3d size = m.V.colwise().maxCoeff() - m.V.colwise().minCoeff();
    EXPECT_NEAR(size.x(), 0.145, 0.1 * 0.145) << seed;
    EXPECT_NEAR(size.z(), 0.355, 0.1 * 0.355) << seed;
    EXPECT_EQ(genus(m), 0) << seed;
    EXPECT_NEAR(m.V.rows(), 1500, 0.02 * 1500);
  }
}

TEST(Generate, Deterministic) {
  SurfaceMesh a = generate_tract({1500, 0}), b = generate_tract({1500, 0});
  EXPECT_EQ(a.V, b.V);
  EXPECT_EQ(a.F, b.F);
  SurfaceMesh c = generate_tract({1500, 7});
  EXPECT_NE(a.V, c.V);
  EXPECT_EQ(generate_tract({1500, 7}).V, c.V);
}

TEST(Generate, StomachMatchesReferenceCounts) {
  SurfaceMesh m = generate_stomach();
  EXPECT_EQ(m.V.rows(), 192);
  EXPECT_EQ(m.F.rows(), 372);
  EXPECT_EQ(m.E.rows(), 564);
  expect_half_edge_invariants(m);
  EXPECT_EQ(boundary_loops(m).size(), 2u);
  EXPECT_EQ(euler_characteristic(m), 0);  // an open tube (annulus)
}

TEST(Generate, SpheresAreGeodesic) {
  EXPECT_EQ(sphere_frequency_for(642), 8);
  EXPECT_EQ(sphere_frequency_for(23522), 48);
  for (int n : {642, 2562, 10242}) {
    SurfaceMesh m = generate_sphere(n);
    EXPECT_EQ(m.V.rows(), n);
    EXPECT_EQ(m.F.rows(), 2 * n - 4);
    EXPECT_EQ(genus(m), 0);
    EXPECT_EQ(euler_characteristic(m), 2);
    for (int v = 0; v < m.V.rows(); ++v) EXPECT_NEAR(m.V.row(v).norm(), 0.05, 1e-15);
    // Inscribed polyhedron: volume slightly below the ball's.
    const double ball = 4.0 / 3.0 * M_PI * 0.05 * 0.05 * 0.05;
    EXPECT_LT(enclosed_volume(m.V, m.F), ball);
    EXPECT_GT(enclosed_volume(m.V, m.F), 0.98 * ball);
  }
  SurfaceMesh big = generate_sphere(23522);
  EXPECT_NEAR(big.V.rows(), 23522, 0.1 * 23522);
  EXPECT_THROW(generate_sphere(5), palplab::InputError);
}
