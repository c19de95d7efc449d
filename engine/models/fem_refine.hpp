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

#include "engine/mesh/tet_mesh.hpp"

namespace palplab::engine {

struct RedRefinement {
  mesh::TetMesh mesh;
  // For each vertex of the refined mesh: its two coarse parents ({v, v} for a kept vertex).
  std::vector<std::array<int, 2>> parent;
  std::vector<int> parent_tet;  // #T_fine: the coarse tet each child lies in
};

RedRefinement refine_red(const mesh::TetMesh& m);

}  // namespace palplab::engine
