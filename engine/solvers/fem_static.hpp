#pragma once
// Dirichlet constraints and the static solve K u = f of the linear FEM.
// Constrained (fixed) dofs carry a prescribed displacement; the system on the free dofs
//   K_ff u_f = f_f - K_fc u_c
// is factorised once and reused for any load: by default with a sparse LDL^T (Eigen
// SimplicialLDLT, AMD ordering); on request with CHOLMOD's supernodal LL^T (METIS / AMD ordering,
// dense BLAS-3 blocks), the factorisation of the large reference levels (docs/ARCHITECTURE.md,
// "Sparse Cholesky": measured side by side, `palplab fem solvers`). Vectors are 3#V long,
// node-major, as in fem_assembly.hpp; forces N, displacements m.
#include <Eigen/SparseCholesky>
#include <cstdint>
#include <memory>
#include <string>
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

// The factorisation of K_ff. ldlt: Eigen SimplicialLDLT (fastest below ~20k free dofs);
// cholmod: CHOLMOD supernodal LL^T (fill-reducing nested dissection, dense supernodes: far less
// fill and time on the 10^5-10^6-dof reference levels); automatic: cholmod from
// kCholmodMinDofs free dofs on, else ldlt. The choice and the threshold are measured
// (docs/ARCHITECTURE.md); both give the same solution to round-off (tests/fem).
enum class SparseSolverKind { ldlt, cholmod, automatic };
inline constexpr long kCholmodMinDofs = 20000;
const char* to_string(SparseSolverKind k);
// "ldlt", "cholmod", "auto"; throws std::invalid_argument otherwise.
SparseSolverKind parse_sparse_solver(const std::string& name);

struct CholmodFactor;  // fem_static.cpp (keeps cholmod.h out of the includes)

struct StaticSolver {
  DofSplit split;
  SparseMatrixd K;  // the full matrix (kept for reactions)
  SparseMatrixd K_ff, K_fc;
  SparseSolverKind kind = SparseSolverKind::ldlt;  // the one used (never automatic)
  SparseLdlt ldlt;                                 // kind == ldlt
  std::shared_ptr<CholmodFactor> cholmod;          // kind == cholmod (shared: immutable)
  double factor_ms = 0;                            // wall time of analyse + factorise
  double factor_nnz = 0;  // stored entries of the factor (supernodal: with the dense blocks)
  // K_ff^-1 B for B (#free by k); any kind.
  Eigen::MatrixXd solve_free(const Eigen::MatrixXd& B) const;
};
// Factorises K_ff. Throws std::runtime_error if K_ff is singular (under-constrained body): a
// (near) zero pivot of the LDL^T, a failed LL^T or a CHOLMOD reciprocal condition estimate
// below 1e-12 (the same bound on the squared pivot ratio).
void static_precompute(const SparseMatrixd& K, const std::vector<std::uint8_t>& fixed_dof,
                       StaticSolver& s, SparseSolverKind kind = SparseSolverKind::ldlt);
// u (3#V): free dofs solved for load f (3#V; fixed entries ignored), fixed dofs = u_fixed
// (3#V; only fixed entries read; pass an empty vector for homogeneous constraints).
Eigen::VectorXd static_solve(const StaticSolver& s, const Eigen::VectorXd& f,
                             const Eigen::VectorXd& u_fixed = {});
// Reaction forces K u - f (3#V, N): zero (to round-off) on free dofs, the force the constraint
// applies on fixed dofs.
Eigen::VectorXd reactions(const SparseMatrixd& K, const Eigen::VectorXd& u,
                          const Eigen::VectorXd& f);

}  // namespace palplab::engine
