#pragma once
// SurfaceMesh: a triangle surface (V, F) with half-edge connectivity.
//
// Half-edges are implicit: half-edge h = 3*f + k runs from F(f,k) to F(f,(k+1)%3) and has face f
// on its left, so next/prev/face/origin are arithmetic and only twin, edge and one outgoing
// half-edge per vertex are stored. Edges shared by more than two faces (non-manifold) or by two
// faces that traverse them in the same direction (inconsistent orientation) get no twin (-1);
// they are listed so that checks can report them and the rest of the mesh still works.
#include <vector>

#include "engine/mesh/types.hpp"

namespace palplab::mesh {

struct SurfaceMesh {
  Positions V;      // #V by 3 positions (m)
  Faces F;          // #F by 3 triangles
  Regions regions;  // per-face named regions (optional)

  // --- connectivity, built by build_connectivity() from F ---
  Edges E;                  // #E by 2 undirected edges, sorted lexicographically
  Eigen::VectorXi twin;     // 3#F opposite half-edge, -1 on boundary / non-manifold / inconsistent
  Eigen::VectorXi he_edge;  // 3#F edge index of each half-edge
  Eigen::VectorXi edge_faces;  // #E number of faces using the edge (1 = boundary, 2 = interior)
  // #V one outgoing half-edge per vertex, -1 for isolated vertices; on a boundary vertex it is
  // the outgoing boundary half-edge, so a fan rotation from it visits every incident face.
  Eigen::VectorXi vertex_he;
  std::vector<int> non_manifold_edges;     // edges with more than two faces
  std::vector<int> inconsistent_edges;     // edges whose two faces traverse them the same way
  std::vector<int> non_manifold_vertices;  // vertices whose faces form more than one fan
};

inline int he_face(int h) {
  return h / 3;
}
inline int he_next(int h) {
  return h - h % 3 + (h % 3 + 1) % 3;
}
inline int he_prev(int h) {
  return h - h % 3 + (h % 3 + 2) % 3;
}
inline int he_origin(const SurfaceMesh& m, int h) {
  return m.F(h / 3, h % 3);
}
inline int he_target(const SurfaceMesh& m, int h) {
  return m.F(h / 3, (h % 3 + 1) % 3);
}

// Builds the mesh and its connectivity. O(#F log #F) (one sort of the half-edges).
// Throws InputError when a face index is out of range.
SurfaceMesh make_surface_mesh(Positions V, Faces F, Regions regions = {});
// Rebuilds the connectivity after F changed.
void build_connectivity(SurfaceMesh& m);

// Neighbours of v in fan order (counter-clockwise seen from outside), O(valence). Exact for
// manifold vertices; for a vertex listed in non_manifold_vertices it returns one fan only.
void one_ring(const SurfaceMesh& m, int v, std::vector<int>& out);
// Faces around v in the same fan order.
void vertex_faces(const SurfaceMesh& m, int v, std::vector<int>& out);

bool is_boundary_vertex(const SurfaceMesh& m, int v);
// Boundary loops as vertex cycles, each in the direction of its boundary half-edges.
std::vector<std::vector<int>> boundary_loops(const SurfaceMesh& m);
int count_boundary_edges(const SurfaceMesh& m);
// Vertices referenced by at least one face.
int count_used_vertices(const SurfaceMesh& m);
// Euler characteristic chi = V - E + F over the vertices referenced by faces.
int euler_characteristic(const SurfaceMesh& m);
// Connected components of faces (through shared vertices); comp has one id per face.
int face_components(const SurfaceMesh& m, Eigen::VectorXi* comp = nullptr);
// True when the faces can be oriented consistently (edge-manifold part; ignores edges with
// more than two faces).
bool is_orientable(const SurfaceMesh& m);
// Closed, edge- and vertex-manifold, orientable: a 2-manifold without boundary.
bool is_closed_manifold(const SurfaceMesh& m);
// Genus of a closed orientable 2-manifold (summed over components), or -1 otherwise.
int genus(const SurfaceMesh& m);

// #F by 3 unit face normals (zero for degenerate faces).
Positions face_normals(const Positions& V, const Faces& F);
// #F face areas (m^2).
Eigen::VectorXd face_areas(const Positions& V, const Faces& F);
// #V by 3 unit vertex normals, area-weighted mean of the incident face normals.
Positions vertex_normals(const Positions& V, const Faces& F);
// Signed volume enclosed by a closed outward-oriented surface (m^3), by the divergence theorem.
double enclosed_volume(const Positions& V, const Faces& F);

// Per-vertex region derived from the per-face regions: the smallest region id among the faces
// of the vertex (so a vertex on the border of two regions belongs to the one listed first).
// -1 where a vertex has no face with a region. Size #V; empty when the mesh has no regions.
Eigen::VectorXi vertex_regions(const SurfaceMesh& m);

}  // namespace palplab::mesh
