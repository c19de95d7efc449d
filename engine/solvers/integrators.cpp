#include "engine/solvers/integrators.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace palplab::engine {

Integrator integrator_from_string(const std::string& s) {
  if (s == "symplectic_euler") return Integrator::symplectic_euler;
  if (s == "backward_euler") return Integrator::backward_euler;
  if (s == "rk4") return Integrator::rk4;
  throw std::invalid_argument("unknown integrator '" + s +
                              "' (expected symplectic_euler, backward_euler or rk4)");
}
const char* to_string(Integrator i) {
  switch (i) {
    case Integrator::symplectic_euler:
      return "symplectic_euler";
    case Integrator::backward_euler:
      return "backward_euler";
    case Integrator::rk4:
      return "rk4";
  }
  return "?";
}
LinearSolver linear_solver_from_string(const std::string& s) {
  if (s == "cg") return LinearSolver::cg;
  if (s == "ldlt_refactor") return LinearSolver::ldlt_refactor;
  if (s == "ldlt_frozen") return LinearSolver::ldlt_frozen;
  throw std::invalid_argument("unknown linear solver '" + s +
                              "' (expected cg, ldlt_refactor or ldlt_frozen)");
}
const char* to_string(LinearSolver s) {
  switch (s) {
    case LinearSolver::cg:
      return "cg";
    case LinearSolver::ldlt_refactor:
      return "ldlt_refactor";
    case LinearSolver::ldlt_frozen:
      return "ldlt_frozen";
  }
  return "?";
}

void activate_all(const MassSpringSystem& sys, ActiveSet& act) {
  const long n = sys.nodes();
  act.nodes.clear();
  act.is_active.assign(n, 0);
  for (long i = 0; i < n; ++i)
    if (sys.fixed.empty() || !sys.fixed[i]) {
      act.nodes.push_back(static_cast<int>(i));
      act.is_active[i] = 1;
    }
  rebuild_active_springs(sys, act);
}

void rebuild_active_springs(const MassSpringSystem& sys, ActiveSet& act) {
  act.springs.clear();
  for (int i : act.nodes)
    for (int k = sys.adj_start[i]; k < sys.adj_start[i + 1]; ++k) {
      const int s = sys.adj_spring[k];
      const int a = sys.springs.E(s, 0), b = sys.springs.E(s, 1);
      const int other = a == i ? b : a;
      // Count each spring once: from its smaller active endpoint.
      if (act.is_active[other] && other < i) continue;
      act.springs.push_back(s);
    }
  std::sort(act.springs.begin(), act.springs.end());
  ++act.version;
}

namespace {

void ensure(RowMatX3d& M, long n) {
  if (M.rows() != n) M.setZero(n, 3);
}

void symplectic_euler(MassSpringSystem& sys, const ActiveSet& act, double h,
                      IntegratorWorkspace& ws) {
  compute_forces(sys, sys.X, sys.V, ws.F, &act.nodes, &act.springs);
  for (int i : act.nodes) {
    sys.V.row(i) += (h / sys.mass[i]) * ws.F.row(i);
    sys.X.row(i) += h * sys.V.row(i);
  }
}

void rk4(MassSpringSystem& sys, const ActiveSet& act, double h, IntegratorWorkspace& ws) {
  const long n = sys.nodes();
  ensure(ws.X1, n);
  ensure(ws.V1, n);
  for (auto& k : ws.kx) ensure(k, n);
  for (auto& k : ws.kv) ensure(k, n);
  // Held (inactive) endpoints of active springs keep their state in the stage buffers.
  for (int s : act.springs)
    for (int e = 0; e < 2; ++e) {
      const int j = sys.springs.E(s, e);
      ws.X1.row(j) = sys.X.row(j);
      ws.V1.row(j) = sys.V.row(j);
    }
  for (int i : act.nodes) {
    ws.X1.row(i) = sys.X.row(i);
    ws.V1.row(i) = sys.V.row(i);
  }
  const double c[4] = {0.0, 0.5, 0.5, 1.0};
  for (int st = 0; st < 4; ++st) {
    if (st > 0)
      for (int i : act.nodes) {
        ws.X1.row(i) = sys.X.row(i) + c[st] * h * ws.kx[st - 1].row(i);
        ws.V1.row(i) = sys.V.row(i) + c[st] * h * ws.kv[st - 1].row(i);
      }
    compute_forces(sys, ws.X1, ws.V1, ws.F, &act.nodes, &act.springs);
    for (int i : act.nodes) {
      ws.kx[st].row(i) = ws.V1.row(i);
      ws.kv[st].row(i) = ws.F.row(i) / sys.mass[i];
    }
  }
  for (int i : act.nodes) {
    sys.X.row(i) +=
        (h / 6.0) * (ws.kx[0].row(i) + 2 * ws.kx[1].row(i) + 2 * ws.kx[2].row(i) + ws.kx[3].row(i));
    sys.V.row(i) +=
        (h / 6.0) * (ws.kv[0].row(i) + 2 * ws.kv[1].row(i) + 2 * ws.kv[2].row(i) + ws.kv[3].row(i));
  }
}

// y = A p on active rows, A = M - h D - h^2 K (PSD-projected), p = 0 on inactive nodes.
void apply_A(const MassSpringSystem& sys, const ActiveSet& act, double h,
             const IntegratorWorkspace& ws, const RowMatX3d& P, RowMatX3d& Y) {
  for (int i : act.nodes)
    Y.row(i) = (sys.mass[i] + h * sys.home_kd[i] + h * h * sys.home_ks[i]) * P.row(i);
  if (ws.contact_on)
    Y.row(sys.contact_node) += (ws.contact_block * P.row(sys.contact_node).transpose()).transpose();
  for (size_t k = 0; k < act.springs.size(); ++k) {
    const int s = act.springs[k];
    const int a = sys.springs.E(s, 0), b = sys.springs.E(s, 1);
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    if (act.is_active[a]) d += P.row(a).transpose();
    if (act.is_active[b]) d -= P.row(b).transpose();
    const Eigen::Vector3d y = ws.S[k] * d;
    if (act.is_active[a]) Y.row(a) += y.transpose();
    if (act.is_active[b]) Y.row(b) -= y.transpose();
  }
}

void backward_euler(MassSpringSystem& sys, const ActiveSet& act, double h,
                    IntegratorWorkspace& ws) {
  const long n = sys.nodes();
  ensure(ws.R, n);
  ensure(ws.P, n);
  ensure(ws.Z, n);
  ensure(ws.AP, n);
  ensure(ws.DV, n);
  if (ws.Dinv.size() < static_cast<size_t>(n)) ws.Dinv.resize(n);
  if (ws.S.size() < act.springs.size()) ws.S.resize(act.springs.size() + act.springs.size() / 2);

  // f0 and the rhs b = h (f0 + h K v0); held nodes count as v = 0.
  compute_forces(sys, sys.X, sys.V, ws.F, &act.nodes, &act.springs);
  for (int i : act.nodes) {
    ws.R.row(i) = h * (ws.F.row(i) - h * sys.home_ks[i] * sys.V.row(i));
    ws.Dinv[i] =
        Eigen::Matrix3d::Identity() * (sys.mass[i] + h * sys.home_kd[i] + h * h * sys.home_ks[i]);
  }
  // Contact penalty: K = -k n n^T while penetrating.
  ws.contact_on = sys.contact_node >= 0 && act.is_active[sys.contact_node] &&
                  contact_penetration(sys, sys.X) > 0.0;
  if (ws.contact_on) {
    const int p = sys.contact_node;
    const Eigen::Matrix3d Kc = -sys.contact_k * sys.contact_normal * sys.contact_normal.transpose();
    ws.contact_block = -(h * h) * Kc;
    ws.R.row(p) += ((h * h) * (Kc * sys.V.row(p).transpose())).transpose();
    ws.Dinv[p] += ws.contact_block;
  }
  Eigen::Matrix3d Kx, Kv;
  for (size_t k = 0; k < act.springs.size(); ++k) {
    const int s = act.springs[k];
    const int a = sys.springs.E(s, 0), b = sys.springs.E(s, 1);
    spring_jacobian(sys.X.row(a).transpose(), sys.X.row(b).transpose(), sys.springs.ks[s],
                    sys.springs.kd[s], sys.springs.rest[s], true, Kx, Kv);
    ws.S[k] = -(h * Kv + h * h * Kx);
    Eigen::Vector3d dv = Eigen::Vector3d::Zero();
    if (act.is_active[a]) dv += sys.V.row(a).transpose();
    if (act.is_active[b]) dv -= sys.V.row(b).transpose();
    const Eigen::Vector3d kv0 = (h * h) * (Kx * dv);
    if (act.is_active[a]) {
      ws.R.row(a) += kv0.transpose();
      ws.Dinv[a] += ws.S[k];
    }
    if (act.is_active[b]) {
      ws.R.row(b) -= kv0.transpose();
      ws.Dinv[b] += ws.S[k];
    }
  }

  if (ws.solver == LinearSolver::cg) {
    for (int i : act.nodes) ws.Dinv[i] = ws.Dinv[i].inverse().eval();
    // Warm start from the previous step's dv; r = b - A x.
    apply_A(sys, act, h, ws, ws.DV, ws.AP);
    double bnorm = 0.0, rz = 0.0;
    for (int i : act.nodes) {
      bnorm += ws.R.row(i).squaredNorm();
      ws.R.row(i) -= ws.AP.row(i);
      ws.Z.row(i) = (ws.Dinv[i] * ws.R.row(i).transpose()).transpose();
      ws.P.row(i) = ws.Z.row(i);
      rz += ws.R.row(i).dot(ws.Z.row(i));
    }
    bnorm = std::sqrt(bnorm);
    int it = 0;
    double rnorm = 0.0;
    for (int i : act.nodes) rnorm += ws.R.row(i).squaredNorm();
    rnorm = std::sqrt(rnorm);
    const double tol = ws.cg_tolerance * (bnorm > 0 ? bnorm : 1.0);
    while (rnorm > tol && it < ws.cg_max_iterations) {
      apply_A(sys, act, h, ws, ws.P, ws.AP);
      double pAp = 0.0;
      for (int i : act.nodes) pAp += ws.P.row(i).dot(ws.AP.row(i));
      if (!(pAp > 0.0)) break;
      const double alpha = rz / pAp;
      double rz_new = 0.0;
      rnorm = 0.0;
      for (int i : act.nodes) {
        ws.DV.row(i) += alpha * ws.P.row(i);
        ws.R.row(i) -= alpha * ws.AP.row(i);
        ws.Z.row(i) = (ws.Dinv[i] * ws.R.row(i).transpose()).transpose();
        rz_new += ws.R.row(i).dot(ws.Z.row(i));
        rnorm += ws.R.row(i).squaredNorm();
      }
      rnorm = std::sqrt(rnorm);
      const double beta = rz_new / rz;
      rz = rz_new;
      for (int i : act.nodes) ws.P.row(i) = ws.Z.row(i) + beta * ws.P.row(i);
      ++it;
    }
    ws.last.cg_iterations = it;
    ws.last.residual = bnorm > 0 ? rnorm / bnorm : rnorm;
  } else {
    const long m = static_cast<long>(act.nodes.size());
    ws.dof_of_node.assign(n, -1);
    for (long k = 0; k < m; ++k) ws.dof_of_node[act.nodes[k]] = static_cast<int>(k);
    // The frozen factorisation is redone when the active set, the contact node/state or h change.
    const int contact_key = ws.contact_on ? sys.contact_node : -1;
    const bool need_factor = ws.solver == LinearSolver::ldlt_refactor ||
                             ws.factor_version != act.version || ws.factor_contact != contact_key ||
                             ws.factor_h != h;
    ws.factor_contact = contact_key;
    ws.factor_h = h;
    if (need_factor) {
      ws.triplets.clear();
      for (long k = 0; k < m; ++k) {
        const int i = act.nodes[k];
        const double d = sys.mass[i] + h * sys.home_kd[i] + h * h * sys.home_ks[i];
        for (int r = 0; r < 3; ++r) ws.triplets.emplace_back(3 * k + r, 3 * k + r, d);
        if (ws.contact_on && i == sys.contact_node)
          for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
              ws.triplets.emplace_back(3 * k + r, 3 * k + c, ws.contact_block(r, c));
      }
      for (size_t k = 0; k < act.springs.size(); ++k) {
        const int s = act.springs[k];
        const int a = ws.dof_of_node[sys.springs.E(s, 0)], b = ws.dof_of_node[sys.springs.E(s, 1)];
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) {
            const double v = ws.S[k](r, c);
            if (a >= 0) ws.triplets.emplace_back(3 * a + r, 3 * a + c, v);
            if (b >= 0) ws.triplets.emplace_back(3 * b + r, 3 * b + c, v);
            if (a >= 0 && b >= 0) {
              ws.triplets.emplace_back(3 * a + r, 3 * b + c, -v);
              ws.triplets.emplace_back(3 * b + r, 3 * a + c, -v);
            }
          }
      }
      ws.A.resize(3 * m, 3 * m);
      ws.A.setFromTriplets(ws.triplets.begin(), ws.triplets.end());
      if (ws.analysed_version != act.version) {
        ws.ldlt.analyzePattern(ws.A);
        ws.analysed_version = act.version;
      }
      ws.ldlt.factorize(ws.A);
      ws.factor_version = act.version;
    }
    ws.b.resize(3 * m);
    for (long k = 0; k < m; ++k) ws.b.segment<3>(3 * k) = ws.R.row(act.nodes[k]).transpose();
    ws.x = ws.ldlt.solve(ws.b);
    for (long k = 0; k < m; ++k) ws.DV.row(act.nodes[k]) = ws.x.segment<3>(3 * k).transpose();
    ws.last.cg_iterations = 0;
    ws.last.residual = 0.0;
  }
  for (int i : act.nodes) {
    sys.V.row(i) += ws.DV.row(i);
    sys.X.row(i) += h * sys.V.row(i);
  }
}

}  // namespace

void integrate(MassSpringSystem& sys, const ActiveSet& act, double h, Integrator method,
               IntegratorWorkspace& ws) {
  ensure(ws.F, sys.nodes());
  switch (method) {
    case Integrator::symplectic_euler:
      symplectic_euler(sys, act, h, ws);
      break;
    case Integrator::backward_euler:
      backward_euler(sys, act, h, ws);
      break;
    case Integrator::rk4:
      rk4(sys, act, h, ws);
      break;
  }
}

}  // namespace palplab::engine
