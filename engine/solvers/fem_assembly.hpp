#pragma once
// Assembly of the linear tetrahedral FEM: per-tet materials from the tissue table,
// the sparse pattern built once (element entry -> value slot), global stiffness K, consistent
// and lumped mass and Rayleigh damping C = alpha M + beta K.
//
// Global vectors have 3 #V entries, node-major (u_x0, u_y0, u_z0, u_x1, ...); matrices are
// 3 #V by 3 #V, column-major sparse with the FULL (both triangles) pattern. Units as in
// fem_element.hpp.
#include <Eigen/SparseCore>
#include <cstdint>
#include <vector>

#include "engine/mesh/materials.hpp"
#include "engine/mesh/tet_mesh.hpp"
#include "engine/solvers/fem_element.hpp"

namespace palplab::engine {

using SparseMatrixd = Eigen::SparseMatrix<double>;

// Per-tet material (all #T long): E (Pa), nu, density (kg/m^3), rigid (bone: its nodes are fixed).
struct TetMaterials {
  Eigen::VectorXd youngs_modulus, poisson_ratio, density;
  std::vector<std::uint8_t> rigid;
  long size() const { return youngs_modulus.size(); }
};
// The materials of each tet from its attribute (tissue type). Throws InputError naming the tet
// when the table has no entry for its attribute.
TetMaterials tet_materials(const mesh::TetMesh& m, const mesh::MaterialTable& table);
// One material for every tet (verification meshes).
TetMaterials uniform_materials(long tets, double youngs_modulus, double poisson_ratio,
                               double density);
// #V flags: 1 for every node of a rigid tet.
std::vector<std::uint8_t> rigid_nodes(const mesh::TetMesh& m, const TetMaterials& mat);

// The sparsity pattern of a tet mesh, built once: slot[144 t + 12 j + i] is the index into
// matrix.valuePtr() of entry (row dof i, column dof j) of tet t. Assembling new element
// matrices then only writes values (no allocation, no sorting).
struct FemPattern {
  SparseMatrixd matrix;  // 3#V by 3#V, compressed, values zero
  std::vector<int> slot;
};
FemPattern build_pattern(const mesh::Tets& T, long nodes);
// out = sum_t scatter(Ke[t]) on the pattern (out is reset to the pattern first if its shape
// differs). Ke has #T entries.
void assemble(const FemPattern& p, const std::vector<Matrix12d>& Ke, SparseMatrixd& out);

// Precomputed linear FEM of a mesh: shapes, element stiffness/mass, and the assembled K, M.
struct FemSystem {
  mesh::Positions X0;  // #V by 3 rest positions (m)
  mesh::Tets T;
  TetMaterials material;
  std::vector<TetShape> shape;  // #T
  std::vector<Matrix12d> Ke;    // #T element stiffness (N/m)
  FemPattern pattern;
  SparseMatrixd K;           // global stiffness (N/m)
  SparseMatrixd M;           // consistent mass (kg)
  Eigen::VectorXd m_lumped;  // 3#V lumped mass per dof (kg)
  long nodes() const { return X0.rows(); }
  long dofs() const { return 3 * X0.rows(); }
};
// Throws InputError for an inverted or degenerate tet (naming it) or invalid material.
FemSystem fem_precompute(const mesh::Positions& X0, const mesh::Tets& T, const TetMaterials& mat);

// C = alpha M + beta K (N s/m); M may be consistent or diag(m_lumped).
SparseMatrixd rayleigh_damping(const SparseMatrixd& M, const SparseMatrixd& K, double alpha,
                               double beta);
SparseMatrixd diagonal_matrix(const Eigen::VectorXd& d);

// Node flags -> dof flags (3 per node).
std::vector<std::uint8_t> node_to_dof_flags(const std::vector<std::uint8_t>& node_flags);
// Positions (#V by 3) <-> dof vectors (3#V).
Eigen::VectorXd flatten(const mesh::Positions& X);
mesh::Positions unflatten(const Eigen::VectorXd& x);

}  // namespace palplab::engine
