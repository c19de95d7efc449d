#include "engine/solvers/fem_static.hpp"

#include <Eigen/CholmodSupport>
#include <chrono>
#include <new>
#include <stdexcept>

namespace palplab::engine {

// Eigen's wrapper, opened up for the reciprocal condition estimate and the factor's size.
struct CholmodFactor : Eigen::CholmodSupernodalLLT<SparseMatrixd, Eigen::Lower> {
  double rcond() { return cholmod_rcond(m_cholmodFactor, &cholmod()); }
  double stored() const {
    return m_cholmodFactor ? static_cast<double>(m_cholmodFactor->is_super ? m_cholmodFactor->xsize
                                                                           : m_cholmodFactor->nzmax)
                           : 0.0;
  }
};

const char* to_string(SparseSolverKind k) {
  switch (k) {
    case SparseSolverKind::ldlt:
      return "ldlt";
    case SparseSolverKind::cholmod:
      return "cholmod";
    case SparseSolverKind::automatic:
      return "auto";
  }
  return "?";
}

SparseSolverKind parse_sparse_solver(const std::string& name) {
  if (name == "ldlt") return SparseSolverKind::ldlt;
  if (name == "cholmod") return SparseSolverKind::cholmod;
  if (name == "auto") return SparseSolverKind::automatic;
  throw std::invalid_argument("expected ldlt, cholmod or auto, got \"" + name + "\"");
}

DofSplit split_dofs(const std::vector<std::uint8_t>& fixed_dof) {
  DofSplit s;
  s.local.resize(fixed_dof.size());
  for (size_t i = 0; i < fixed_dof.size(); ++i) {
    if (fixed_dof[i]) {
      s.local[i] = -static_cast<int>(s.fixed.size()) - 1;
      s.fixed.push_back(static_cast<int>(i));
    } else {
      s.local[i] = static_cast<int>(s.free.size());
      s.free.push_back(static_cast<int>(i));
    }
  }
  return s;
}

SparseMatrixd submatrix(const SparseMatrixd& A, const std::vector<int>& rows,
                        const std::vector<int>& cols) {
  std::vector<int> row_map(A.rows(), -1);
  for (size_t i = 0; i < rows.size(); ++i) row_map[rows[i]] = static_cast<int>(i);
  std::vector<Eigen::Triplet<double>> trip;
  for (size_t j = 0; j < cols.size(); ++j)
    for (SparseMatrixd::InnerIterator it(A, cols[j]); it; ++it)
      if (row_map[it.row()] >= 0)
        trip.emplace_back(row_map[it.row()], static_cast<int>(j), it.value());
  SparseMatrixd S(static_cast<long>(rows.size()), static_cast<long>(cols.size()));
  S.setFromTriplets(trip.begin(), trip.end());
  S.makeCompressed();
  return S;
}

Eigen::VectorXd gather(const Eigen::VectorXd& x, const std::vector<int>& idx) {
  Eigen::VectorXd y(idx.size());
  for (size_t i = 0; i < idx.size(); ++i) y[i] = x[idx[i]];
  return y;
}

void scatter(const Eigen::VectorXd& xs, const std::vector<int>& idx, Eigen::VectorXd& x) {
  for (size_t i = 0; i < idx.size(); ++i) x[idx[i]] = xs[i];
}

void static_precompute(const SparseMatrixd& K, const std::vector<std::uint8_t>& fixed_dof,
                       StaticSolver& s, SparseSolverKind kind) {
  if (static_cast<long>(fixed_dof.size()) != K.rows())
    throw std::invalid_argument("static_precompute: fixed_dof size != K rows");
  const auto t0 = std::chrono::steady_clock::now();
  s.split = split_dofs(fixed_dof);
  s.K = K;
  s.K_ff = submatrix(K, s.split.free, s.split.free);
  s.K_fc = submatrix(K, s.split.free, s.split.fixed);
  if (kind == SparseSolverKind::automatic)
    kind = static_cast<long>(s.split.free.size()) >= kCholmodMinDofs ? SparseSolverKind::cholmod
                                                                     : SparseSolverKind::ldlt;
  s.kind = kind;
  const char* singular =
      "static_precompute: singular stiffness (the constraints leave a rigid-body mode free)";
  if (kind == SparseSolverKind::cholmod) {
    auto c = std::make_shared<CholmodFactor>();
    c->compute(s.K_ff);
    // Out of memory is not a singular matrix (`fem reference --mem-limit-gb`).
    if (c->cholmod().status == CHOLMOD_OUT_OF_MEMORY) throw std::bad_alloc();
    // LL^T fails on a matrix that is not positive definite; a rigid mode may survive round-off
    // as a tiny positive pivot, which the condition estimate catches.
    if (c->info() != Eigen::Success || (s.K_ff.rows() > 0 && !(c->rcond() > 1e-12)))
      throw std::runtime_error(singular);
    s.factor_nnz = c->stored();
    s.cholmod = std::move(c);
  } else {
    s.cholmod.reset();
    s.ldlt.compute(s.K_ff);
    if (s.ldlt.info() != Eigen::Success)
      throw std::runtime_error("static_precompute: stiffness factorisation failed");
    // LDL^T does not fail on a singular matrix; a rigid mode shows as a (near) zero pivot.
    const Eigen::VectorXd d = s.ldlt.vectorD();
    if (d.size() && d.cwiseAbs().minCoeff() <= 1e-12 * d.cwiseAbs().maxCoeff())
      throw std::runtime_error(singular);
    s.factor_nnz = static_cast<double>(s.ldlt.matrixL().nestedExpression().nonZeros()) +
                   static_cast<double>(d.size());
  }
  s.factor_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

Eigen::VectorXd static_solve(const StaticSolver& s, const Eigen::VectorXd& f,
                             const Eigen::VectorXd& u_fixed) {
  Eigen::VectorXd rhs = gather(f, s.split.free);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(f.size());
  if (u_fixed.size()) {
    const Eigen::VectorXd uc = gather(u_fixed, s.split.fixed);
    rhs -= s.K_fc * uc;
    scatter(uc, s.split.fixed, u);
  }
  scatter(s.solve_free(rhs), s.split.free, u);
  return u;
}

Eigen::MatrixXd StaticSolver::solve_free(const Eigen::MatrixXd& B) const {
  if (kind == SparseSolverKind::cholmod) {
    if (!cholmod) throw std::logic_error("StaticSolver: not factorised");
    return cholmod->solve(B);
  }
  return ldlt.solve(B);
}

Eigen::VectorXd reactions(const SparseMatrixd& K, const Eigen::VectorXd& u,
                          const Eigen::VectorXd& f) {
  return K * u - f;
}

}  // namespace palplab::engine
