#include "engine/solvers/ldlt_factor.hpp"

#include <stdexcept>

namespace palplab::engine {

LdltFactor LdltFactor::from(const SparseLdlt& ldlt) {
  if (ldlt.info() != Eigen::Success)
    throw std::invalid_argument("LdltFactor: the factorisation did not succeed");
  LdltFactor f;
  f.L = ldlt.matrixL().nestedExpression();
  f.L.makeCompressed();
  f.D = ldlt.vectorD();
  f.P = ldlt.permutationP();
  f.Pinv = ldlt.permutationPinv();
  return f;
}

namespace {
template <class M>
void solve_in_place(const LdltFactor& f, M& x) {
  if (f.P.size() > 0) x = f.P * x;
  if (f.L.nonZeros() > 0) f.L.triangularView<Eigen::UnitLower>().solveInPlace(x);
  if (f.D.size() > 0) x = f.D.asDiagonal().inverse() * x;
  if (f.L.nonZeros() > 0) f.L.adjoint().triangularView<Eigen::UnitUpper>().solveInPlace(x);
  if (f.P.size() > 0) x = f.Pinv * x;
}
}  // namespace

Eigen::MatrixXd LdltFactor::solve(const Eigen::MatrixXd& b) const {
  Eigen::MatrixXd x = b;
  solve_in_place(*this, x);
  return x;
}

Eigen::VectorXd LdltFactor::solve(const Eigen::VectorXd& b) const {
  Eigen::VectorXd x = b;
  solve_in_place(*this, x);
  return x;
}

}  // namespace palplab::engine
