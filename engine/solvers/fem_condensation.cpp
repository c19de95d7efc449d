#include "engine/solvers/fem_condensation.hpp"

#include <chrono>
#include <stdexcept>

namespace palplab::engine {

std::vector<std::uint8_t> operational_nodes(const mesh::Tets& T, long nodes,
                                            const std::vector<std::uint8_t>& operational_tet) {
  std::vector<std::uint8_t> op(nodes, 0);
  for (long t = 0; t < T.rows(); ++t)
    if (operational_tet[t])
      for (int k = 0; k < 4; ++k) op[T(t, k)] = 1;
  return op;
}

namespace {
void check_factor(const SparseLdlt& l, const char* what) {
  if (l.info() != Eigen::Success) throw std::runtime_error(std::string("condensation: ") + what);
  const Eigen::VectorXd d = l.vectorD();
  if (d.size() && d.cwiseAbs().minCoeff() <= 1e-12 * d.cwiseAbs().maxCoeff())
    throw std::runtime_error(std::string("condensation: singular ") + what);
}
}  // namespace

SparseMatrixd schur_reduce(const SparseMatrixd& A, const std::vector<int>& dofs_I,
                           const std::vector<int>& dofs_s, const std::vector<int>& dofs_i,
                           SparseLdlt& ldlt_ii, Eigen::MatrixXd& A_star) {
  const long nI = static_cast<long>(dofs_I.size()), ns = static_cast<long>(dofs_s.size());
  const SparseMatrixd A_ss = submatrix(A, dofs_s, dofs_s);
  A_star = Eigen::MatrixXd(A_ss);
  if (!dofs_i.empty()) {
    const SparseMatrixd A_ii = submatrix(A, dofs_i, dofs_i);
    const SparseMatrixd A_is = submatrix(A, dofs_i, dofs_s);
    ldlt_ii.compute(A_ii);
    check_factor(ldlt_ii, "interior block K_ii");
    const Eigen::MatrixXd X = ldlt_ii.solve(Eigen::MatrixXd(A_is));  // A_ii^-1 A_is
    A_star.noalias() -= A_is.transpose() * X;
    A_star = 0.5 * (A_star + A_star.transpose()).eval();
  }
  std::vector<int> reduced = dofs_I;
  reduced.insert(reduced.end(), dofs_s.begin(), dofs_s.end());
  const SparseMatrixd A_r0 = submatrix(A, reduced, dofs_I);  // columns of I (rows I and s)
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(A_r0.nonZeros() * 2 + ns * ns);
  for (long j = 0; j < A_r0.outerSize(); ++j)
    for (SparseMatrixd::InnerIterator it(A_r0, j); it; ++it) {
      trip.emplace_back(it.row(), j, it.value());
      if (it.row() >= nI) trip.emplace_back(j, it.row(), it.value());  // A_Is = A_sI^T
    }
  for (long j = 0; j < ns; ++j)
    for (long i = 0; i < ns; ++i)
      if (A_star(i, j) != 0.0) trip.emplace_back(nI + i, nI + j, A_star(i, j));
  SparseMatrixd A_r(nI + ns, nI + ns);
  A_r.setFromTriplets(trip.begin(), trip.end());
  A_r.makeCompressed();
  return A_r;
}

void condense_precompute(const SparseMatrixd& K, const mesh::Tets& T,
                         const std::vector<std::uint8_t>& fixed_dof,
                         const std::vector<std::uint8_t>& operational_tet, CondensedFem& c) {
  const auto t0 = std::chrono::steady_clock::now();
  const long nodes = K.rows() / 3;
  std::vector<std::uint8_t> op(nodes, 0), nonop(nodes, 0);
  bool any = false;
  for (long t = 0; t < T.rows(); ++t)
    for (int k = 0; k < 4; ++k) {
      (operational_tet[t] ? op : nonop)[T(t, k)] = 1;
      any = any || operational_tet[t];
    }
  if (!any) throw std::invalid_argument("condensation: no operational tet");
  c.dofs_I.clear();
  c.dofs_s.clear();
  c.dofs_i.clear();
  for (long d = 0; d < K.rows(); ++d) {
    if (fixed_dof[d]) continue;
    const long v = d / 3;
    if (op[v] && nonop[v])
      c.dofs_s.push_back(static_cast<int>(d));
    else if (op[v])
      c.dofs_I.push_back(static_cast<int>(d));
    else if (nonop[v])
      c.dofs_i.push_back(static_cast<int>(d));
  }
  c.reduced = c.dofs_I;
  c.reduced.insert(c.reduced.end(), c.dofs_s.begin(), c.dofs_s.end());
  c.K_r = schur_reduce(K, c.dofs_I, c.dofs_s, c.dofs_i, c.ldlt_ii, c.K_star);
  c.K_si = submatrix(K, c.dofs_s, c.dofs_i);
  c.K_is = submatrix(K, c.dofs_i, c.dofs_s);
  c.ldlt_r.compute(c.K_r);
  check_factor(c.ldlt_r, "reduced system");
  c.precompute_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

Eigen::VectorXd condensed_solve(const CondensedFem& c, const Eigen::VectorXd& f,
                                bool recover_interior) {
  Eigen::VectorXd rhs = gather(f, c.reduced);
  const long nI = static_cast<long>(c.dofs_I.size());
  const Eigen::VectorXd f_i = gather(f, c.dofs_i);
  const bool interior_load = f_i.size() && f_i.cwiseAbs().maxCoeff() > 0;
  if (interior_load) rhs.tail(c.dofs_s.size()) -= c.K_si * c.ldlt_ii.solve(f_i);  // + P* f_i
  const Eigen::VectorXd ur = c.ldlt_r.solve(rhs);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(f.size());
  scatter(ur, c.reduced, u);
  if (recover_interior && !c.dofs_i.empty()) {
    const Eigen::VectorXd us = ur.tail(c.dofs_s.size());
    scatter(c.ldlt_ii.solve(f_i - c.K_is * us), c.dofs_i, u);
  }
  (void)nI;
  return u;
}

}  // namespace palplab::engine
