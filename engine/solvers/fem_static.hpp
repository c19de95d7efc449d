#pragma once
// Dirichlet constraints and the static solve K u = f of the linear FEM.
// Constrained (fixed) dofs carry a prescribed displacement; the system on the free dofs
//   K_ff u_f = f_f - K_fc u_c
// is factorised once with a sparse LDL^T (Eigen SimplicialLDLT, AMD ordering) and reused for any
// load. Vectors are 3#V long, node-major, as in fem_assembly.hpp; forces N, displacements m.
#include <Eigen/SparseCholesky>
#include <cstdint>
#include <vector>

#include "engine/solvers/fem_assembly.hpp"

namespace palplab::engine {

// Partition of the dofs into free and fixed ones.
struct DofSplit {
  std::vector<int> free, fixed;  // global dof indices, ascending
  std::vector<int> local;        // 3#V: index into free (>= 0) or -(index into fixed) - 1
};
DofSplit split_dofs(const std::vector<std::uint8_t>& fixed_dof);

// A(rows, cols) as a new compressed sparse matrix (rows/cols ascending global indices).
SparseMatrixd submatrix(const SparseMatrixd& A, const std::vector<int>& rows,
                        const std::vector<int>& cols);
Eigen::VectorXd gather(const Eigen::VectorXd& x, const std::vector<int>& idx);
void scatter(const Eigen::VectorXd& xs, const std::vector<int>& idx, Eigen::VectorXd& x);

using SparseLdlt = Eigen::SimplicialLDLT<SparseMatrixd, Eigen::Lower>;

struct StaticSolver {
  DofSplit split;
  SparseMatrixd K;  // the full matrix (kept for reactions)
  SparseMatrixd K_ff, K_fc;
  SparseLdlt ldlt;
  double factor_ms = 0;  // wall time of analyse + factorise
};
// Factorises K_ff. Throws std::runtime_error if K_ff is singular (under-constrained body).
void static_precompute(const SparseMatrixd& K, const std::vector<std::uint8_t>& fixed_dof,
                       StaticSolver& s);
// u (3#V): free dofs solved for load f (3#V; fixed entries ignored), fixed dofs = u_fixed
// (3#V; only fixed entries read; pass an empty vector for homogeneous constraints).
Eigen::VectorXd static_solve(const StaticSolver& s, const Eigen::VectorXd& f,
                             const Eigen::VectorXd& u_fixed = {});
// Reaction forces K u - f (3#V, N): zero (to round-off) on free dofs, the force the constraint
// applies on fixed dofs.
Eigen::VectorXd reactions(const SparseMatrixd& K, const Eigen::VectorXd& u,
                          const Eigen::VectorXd& f);

}  // namespace palplab::engine
