#include "engine/solvers/fem_contact_compliance.hpp"

#include <Eigen/Cholesky>
#include <chrono>
#include <stdexcept>
#include <string>

namespace palplab::engine {

void contact_compliance_precompute(const StaticSolver& s, const std::vector<int>& touch_nodes,
                                   const Eigen::VectorXd& f_nocontact, ContactCompliance& c) {
  const auto t0 = std::chrono::steady_clock::now();
  const long n = static_cast<long>(s.split.local.size());
  c.touch_nodes = touch_nodes;
  c.slot.assign(n / 3, -1);
  const long m = static_cast<long>(touch_nodes.size());
  const long nf = static_cast<long>(s.split.free.size());
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(nf, 3 * m);
  for (long k = 0; k < m; ++k) {
    const int v = touch_nodes[k];
    if (v < 0 || v >= n / 3) throw std::invalid_argument("contact compliance: bad node index");
    c.slot[v] = static_cast<int>(k);
    for (int a = 0; a < 3; ++a) {
      const int l = s.split.local[3 * v + a];
      if (l < 0)
        throw std::invalid_argument("contact compliance: touch node " + std::to_string(v) +
                                    " is fixed");
      rhs(l, 3 * k + a) = 1.0;
    }
  }
  const Eigen::MatrixXd Cf = s.solve_free(rhs);
  c.C = Eigen::MatrixXd::Zero(n, 3 * m);
  for (long i = 0; i < nf; ++i) c.C.row(s.split.free[i]) = Cf.row(i);
  c.u0 = static_solve(s, f_nocontact.size() ? f_nocontact : Eigen::VectorXd::Zero(n));
  c.precompute_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

void contact_solve(const ContactCompliance& c, const std::vector<ContactConstraint>& contact,
                   ContactSolution& out, bool want_field) {
  const long k = static_cast<long>(contact.size());
  Eigen::VectorXd rhs(k);
  for (long j = 0; j < k; ++j) {
    const ContactConstraint& q = contact[j];
    if (q.node < 0 || q.node >= static_cast<int>(c.slot.size()) || c.slot[q.node] < 0)
      throw std::invalid_argument("contact_solve: node " + std::to_string(q.node) +
                                  " is not touchable");
    rhs[j] = q.displacement - q.direction.dot(c.u0.segment<3>(3 * q.node));
  }
  // A = N^T C_bb N (k by k, symmetric positive definite): only the contact rows of C are read.
  Eigen::MatrixXd A(k, k);
  for (long j = 0; j < k; ++j)
    for (long i = 0; i < k; ++i)
      A(i, j) = contact[i].direction.dot(
          c.C.block<3, 3>(3 * contact[i].node, 3 * c.slot[contact[j].node]) * contact[j].direction);
  out.force = A.ldlt().solve(rhs);
  if (!want_field) return;
  out.u = c.u0;
  for (long j = 0; j < k; ++j)
    out.u.noalias() +=
        c.C.middleCols<3>(3 * c.slot[contact[j].node]) * (contact[j].direction * out.force[j]);
}

}  // namespace palplab::engine
