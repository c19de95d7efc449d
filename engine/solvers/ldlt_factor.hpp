#pragma once
// A sparse LDL^T factorisation P A P^T = L D L^T held as plain data: L (compressed column, unit
// lower triangular; its diagonal is implied), D and the fill-reducing permutation P. It is made
// from Eigen's SimplicialLDLT through its public accessors, or restored from a file (.psim,
// engine/models/stored_factor.hpp). solve() performs the operations of SimplicialLDLT::solve in
// the same order (permute, unit-lower solve, divide by D, unit-upper solve, permute back), so a
// factor and its restored copy solve bit-identically.
#include <Eigen/SparseCholesky>

#include "engine/solvers/fem_static.hpp"

namespace palplab::engine {

struct LdltFactor {
  SparseMatrixd L;  // n x n, compressed; entries below the diagonal are used
  Eigen::VectorXd D;
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> P, Pinv;

  // The factors of a successful factorisation (throws std::invalid_argument otherwise).
  static LdltFactor from(const SparseLdlt& ldlt);
  long size() const { return D.size(); }
  // A^-1 b for b with size() rows (one or more columns).
  Eigen::MatrixXd solve(const Eigen::MatrixXd& b) const;
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const;
};

}  // namespace palplab::engine
