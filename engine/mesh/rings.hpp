#pragma once
// First- and second-ring tables as compact CSR arrays, precomputed once per mesh.
//   first.row(v)   nodes sharing an edge with v (ascending)
//   second.row(v)  neighbours of the first ring, excluding v and the first ring (ascending)
#include "engine/mesh/types.hpp"

namespace palplab::mesh {

struct RingTable {
  Csr first;
  Csr second;
};

// nV  number of nodes; E  #E by 2 edges (any mesh: surface edges or tet edges, unique_edges).
RingTable compute_rings(int nV, const Edges& E);

}  // namespace palplab::mesh
