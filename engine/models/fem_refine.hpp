#pragma once
// Uniform red refinement of a tetrahedral mesh (Bey 1995, "Tetrahedral grid refinement",
// Computing 55): every tet is split 1 -> 8 at its edge midpoints — four corner tets and the
// inner octahedron cut along its shortest diagonal (which keeps the shape quality bounded over
// repeated refinements). The refined mesh is NESTED in the coarse one: every coarse tet is the
// union of its eight children, so the piecewise-linear FE space of the coarse mesh is a subspace
// of the fine one and the domain is exactly the coarse polyhedron at every level (midpoints lie
// on straight coarse edges: the surface is NOT moved towards a smooth underlying surface).
// The mesh size halves per refinement, the tet count grows 8x.
//
// Vertex numbering: the coarse vertices keep their indices 0..#V-1; the midpoints follow, in
// edge order. Children inherit the attribute and named region of their parent; every child is
// positively oriented (tet_mesh.hpp).
#include <array>
#include <vector>

#include "engine/mesh/surface_mesh.hpp"
#include "engine/mesh/tet_mesh.hpp"

namespace palplab::engine {

struct RedRefinement {
  mesh::TetMesh mesh;
  // For each vertex of the refined mesh: its two coarse parents ({v, v} for a kept vertex).
  std::vector<std::array<int, 2>> parent;
  std::vector<int> parent_tet;  // #T_fine: the coarse tet each child lies in
};

RedRefinement refine_red(const mesh::TetMesh& m);

// Local grading of a closed triangulated surface around a point (the press of the FEM
// reference, fem_reference.hpp): `rounds` rounds of 2D red-green refinement; round j splits
// 1 -> 4 at the edge midpoints every face within radius_j = radius (rounds - j) / rounds
// + the face's own size of `point`, closes the pattern (a face with two or three split edges is
// split 1 -> 4 too, one with one split edge is bisected 1 -> 2 from the opposite vertex), so the
// result is conforming and edges under the point shrink by 2^rounds. The geometry is that of the
// input polyhedron (midpoints on straight edges); the input vertices keep their indices (new
// ones are appended); orientation and face regions carry over to the children.
mesh::SurfaceMesh refine_surface_near(const mesh::SurfaceMesh& s, const Eigen::Vector3d& point,
                                      double radius, int rounds);

}  // namespace palplab::engine
