#pragma once
// The undirected edges of a simplicial mesh (libigl style: one function, plain arrays).
//   F  #F by 3 triangles, or T  #T by 4 tetrahedra (any vertex order)
//   returns E  #E by 2, every pair of vertices sharing an element once, E(e,0) < E(e,1),
//   rows sorted lexicographically (so equal meshes give equal E, and a row can be bisected).
// The one edge extraction of palplab: surface edges (springs of a surface model, refinement,
// rings of prototype B) and tet edges (springs of a volume model, `mesh info`).
#include "engine/mesh/types.hpp"

namespace palplab::mesh {

Edges unique_edges(const Faces& F);
Edges unique_edges(const Tets& T);

}  // namespace palplab::mesh
