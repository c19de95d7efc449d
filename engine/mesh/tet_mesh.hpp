#pragma once
// TetMesh: a tetrahedral mesh (V, T) with a per-tet region attribute, stored volumes, the
// vertex -> tets map, and boundary-face extraction in O(n).
//
// Orientation (same as TetGen's output): tet (a,b,c,d) is positive when
// (b-a)·((c-a)×(d-a)) > 0. Its faces, oriented outwards, are
//   face 0 (opposite a) = (b,c,d), face 1 = (a,d,c), face 2 = (a,b,d), face 3 = (a,c,b).
#include <functional>
#include <utility>
#include <vector>

#include "engine/mesh/types.hpp"

namespace palplab::mesh {

struct TetMesh {
  Positions V;                // #V by 3 positions (m)
  Tets T;                     // #T by 4 tetrahedra
  Eigen::VectorXi attribute;  // #T region attribute = tissue type (tissue table), 0 if none
  Regions regions;            // optional named regions per tet (ovary_left, ...)
  Eigen::VectorXd volume;     // #T unsigned volumes |(d−a)·((d−b)×(d−c))|/6 (m^3)
  Csr vertex_tets;            // #V rows: the tets incident to each vertex (ascending)
};

// Local vertex indices of the four outward faces (see above).
inline constexpr int kTetFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

// Builds the mesh, its volumes and vertex->tets map. attribute may be empty (all 0).
// Throws InputError when an index is out of range or sizes disagree.
TetMesh make_tet_mesh(Positions V, Tets T, Eigen::VectorXi attribute = {}, Regions regions = {});

// Signed volume (b-a)·((c-a)×(d-a))/6 (m^3); positive for a well-oriented tet.
double signed_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);
double signed_volume(const Positions& V, const Tets& T, int t);

// Radius ratio 3·r_in/R_circ in [0, 1]: 1 for the regular tet, -> 0 for slivers and needles.
double radius_ratio(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

// Which faces count as boundary.
struct BoundaryOptions {
  // Also report faces between two tets of different attribute (tissue interfaces), once,
  // from the tet with the smaller attribute.
  bool tissue_interfaces = false;
  // Skip faces whose tet on the other side is rigid (bone), and the outer faces of rigid tets
  // themselves when skip_rigid_outer is set; rigid(attribute) says which tissue is rigid.
  bool skip_towards_rigid = false;
  bool skip_rigid_outer = false;
  std::function<bool(int)> rigid = [](int a) { return a >= 200 && a <= 299; };
};

struct BoundaryFaces {
  Faces F;                // #B by 3 outward-oriented triangles (vertex indices of the tet mesh)
  Eigen::VectorXi tet;    // #B owning tet
  Eigen::VectorXi local;  // #B local face index 0..3 in the owning tet
};

// Boundary faces through the vertex->tets map: for each tet face, the other tets containing
// it are among the tets of its smallest vertex. O(#T · valence) — linear in the mesh size.
// Faces come out in (tet, local face) order.
BoundaryFaces boundary_faces(const TetMesh& m, const BoundaryOptions& opt = {});
// The same by comparing every pair of tets, O(#T^2): the baseline for tests and
// benchmarks only.
BoundaryFaces boundary_faces_brute_force(const TetMesh& m, const BoundaryOptions& opt = {});

// #T by 4 neighbour across each local face (face k is opposite vertex k), -1 on the boundary.
Tets tet_neighbours(const TetMesh& m);

// The tets' connectivity defects: a tet naming a node twice, a tet with the same four nodes as
// an earlier one (it counts its mass and stiffness twice), and a node no tet names (it has
// neither). `mesh check` reports them; the tet models refuse them (check_tet_connectivity).
// Indices outside [0, n_vertices) are skipped (make_tet_mesh refuses them).
struct TetConnectivity {
  std::vector<int> repeated_node;                  // tets naming a node twice, ascending
  std::vector<std::pair<int, int>> duplicate_tet;  // (first tet, its repeat), by the repeat
  std::vector<int> unused_vertex;                  // ascending
};
TetConnectivity tet_connectivity(const Tets& T, long n_vertices);

// Per-vertex named region of a tet mesh derived from the per-tet regions (smallest id).
Eigen::VectorXi vertex_regions(const TetMesh& m);

}  // namespace palplab::mesh
