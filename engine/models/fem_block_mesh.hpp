#pragma once
// Structured tetrahedral blocks for FEM verification: an nx by ny by nz grid of hexahedra over
// [0, size_x] x [0, size_y] x [0, size_z] (m), each hex split into 6 tets around its main
// diagonal (Kuhn/Freudenthal split; the same split in every hex keeps the mesh conforming).
// Node (i, j, k) has index i + (nx+1) (j + (ny+1) k). Tets are positively oriented; every tet
// gets `attribute`. jitter > 0 moves interior nodes by up to jitter times the cell size in
// each axis (deterministic pseudo-random, seed), for patch tests on irregular meshes.
#include <cstdint>

#include "engine/mesh/tet_mesh.hpp"

namespace palplab::engine {

mesh::TetMesh fem_block_mesh(int nx, int ny, int nz, const Eigen::Vector3d& size,
                             int attribute = 101, double jitter = 0.0, std::uint64_t seed = 1);

}  // namespace palplab::engine
