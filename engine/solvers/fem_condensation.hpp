#pragma once
// Hybrid condensed FEM: static condensation of the non-operational region.
//
// The tets are split into an operational region (where the tool acts) and the rest. The free
// dofs fall into three sets: I (nodes touching only operational tets), s (interface: nodes
// touching both) and i (interior of the rest: nodes touching only non-operational tets). No
// tet couples I and i, so K_Ii = 0 and eliminating i is exact:
//   K*  = K_ss - K_si K_ii^-1 K_is                      (dense, #s by #s, precomputed)
//   P*  = -K_si K_ii^-1                                 (load condensation, applied as solves)
//   [K_II K_Is; K_sI K*] [u_I; u_s] = [f_I; f_s + P* f_i],
//   u_i = K_ii^-1 (f_i - K_is u_s)                      (recovery, only when wanted).
// The reduced matrix is factorised once; a run-time solve touches only I and s (plus one sparse
// solve on i when interior loads or interior displacements are asked for). Constraints are
// homogeneous (fixed dofs do not move). Vectors are 3#V, node-major.
#include <cstdint>
#include <vector>

#include "engine/solvers/fem_static.hpp"

namespace palplab::engine {

struct CondensedFem {
  std::vector<int> dofs_I, dofs_s, dofs_i;  // global free dofs of each set, ascending
  std::vector<int> reduced;                 // dofs_I then dofs_s (order of the reduced system)
  SparseMatrixd K_r;                        // reduced matrix over `reduced`
  Eigen::MatrixXd K_star;                   // #s by #s
  SparseMatrixd K_si, K_is;
  SparseLdlt ldlt_r, ldlt_ii;
  double precompute_ms = 0;
};

// Operational node flags from per-tet flags: a node is operational when it touches an
// operational tet (I or s).
std::vector<std::uint8_t> operational_nodes(const mesh::Tets& T, long nodes,
                                            const std::vector<std::uint8_t>& operational_tet);

// K: full 3#V stiffness; fixed_dof: 3#V; operational_tet: #T. Throws std::invalid_argument
// when there is no operational tet, std::runtime_error when a block is singular.
void condense_precompute(const SparseMatrixd& K, const mesh::Tets& T,
                         const std::vector<std::uint8_t>& fixed_dof,
                         const std::vector<std::uint8_t>& operational_tet, CondensedFem& c);

// Reduced matrix with the Schur complement in place of K_ss, for any symmetric A with the same
// pattern as K (e.g. M + hC + h^2 K of backward Euler): A_r = [A_II A_Is; A_sI A_ss - A_si
// A_ii^-1 A_is]. Used by condense_precompute and by the condensed dynamics of FemModel.
SparseMatrixd schur_reduce(const SparseMatrixd& A, const std::vector<int>& dofs_I,
                           const std::vector<int>& dofs_s, const std::vector<int>& dofs_i,
                           SparseLdlt& ldlt_ii, Eigen::MatrixXd& A_star);

// u (3#V) under the load f (3#V). recover_interior = false leaves u_i = 0 (the run-time path
// when only the operational region is needed, e.g. for the haptic force).
Eigen::VectorXd condensed_solve(const CondensedFem& c, const Eigen::VectorXd& f,
                                bool recover_interior = true);

}  // namespace palplab::engine
