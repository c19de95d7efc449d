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

SpringBlocks spring_blocks_from_string(const std::string& s) {
  if (s == "matrix") return SpringBlocks::matrix;
  if (s == "rank_one") return SpringBlocks::rank_one;
  throw std::invalid_argument("unknown spring blocks '" + s + "' (expected matrix or rank_one)");
}
const char* to_string(SpringBlocks b) {
  return b == SpringBlocks::matrix ? "matrix" : "rank_one";
}

WarmStart warm_start_from_string(const std::string& s) {
  if (s == "previous") return WarmStart::previous;
  if (s == "extrapolated") return WarmStart::extrapolated;
  throw std::invalid_argument("unknown warm start '" + s + "' (expected previous or extrapolated)");
}
const char* to_string(WarmStart w) {
  return w == WarmStart::previous ? "previous" : "extrapolated";
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

// Assembles A = M - h D - h^2 K (PSD-projected) over the active nodes (in act.nodes order) and
// factorises it (sparse LDLT; the pattern is analysed once per active set).
void factor_A(const MassSpringSystem& sys, const ActiveSet& act, double h,
              IntegratorWorkspace& ws) {
  const long n = sys.nodes();
  const long m = static_cast<long>(act.nodes.size());
  ws.dof_of_node.assign(n, -1);
  for (long k = 0; k < m; ++k) ws.dof_of_node[act.nodes[k]] = static_cast<int>(k);
  ws.factor_contact = ws.contact_on ? sys.contact_node : -1;
  ws.factor_contact_k = ws.contact_on ? sys.contact_k : 0.0;
  ws.factor_h = h;
  ws.triplets.clear();
  for (long k = 0; k < m; ++k) {
    const int i = act.nodes[k];
    const double d = sys.mass[i] + h * sys.home_kd[i] + h * h * sys.home_ks[i];
    for (int r = 0; r < 3; ++r) ws.triplets.emplace_back(3 * k + r, 3 * k + r, d);
  }
  for (size_t q = 0; q < ws.contact_blocks.size(); ++q) {
    const int k = ws.dof_of_node[ws.contact_block_node[q]];
    if (k < 0) continue;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        ws.triplets.emplace_back(3 * k + r, 3 * k + c, ws.contact_blocks[q](r, c));
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

// Compact, branch-free data of an active set for CG: local 0..m-1 indices, springs with both
// ends active (inner) and with one end held (their block only adds to the active end's diagonal).
void rebuild_compact(const MassSpringSystem& sys, const ActiveSet& act, CompactCg& C) {
  const long n = sys.nodes();
  if (static_cast<long>(C.local.size()) != n) {
    C.local.assign(n, -1);
  } else {
    for (int i : C.prev_nodes) C.local[i] = -1;
  }
  for (size_t k = 0; k < act.nodes.size(); ++k) C.local[act.nodes[k]] = static_cast<int>(k);
  C.prev_nodes = act.nodes;
  C.inner.clear();
  C.held.clear();
  C.ends.resize(act.springs.size());
  for (size_t k = 0; k < act.springs.size(); ++k) {
    const int s = act.springs[k];
    const int a = C.local[sys.springs.E(s, 0)], b = C.local[sys.springs.E(s, 1)];
    C.ends[k] = {a, b};
    if (a >= 0 && b >= 0)
      C.inner.push_back({a, b, static_cast<int>(k)});
    else
      C.held.push_back({a >= 0 ? a : b, -1, static_cast<int>(k)});
  }
  C.iblocks.resize(C.inner.size());
  for (size_t j = 0; j < C.inner.size(); ++j)
    C.iblocks[j] = {0.0, 0.0, 0.0, 0.0, 0.0, C.inner[j].a, C.inner[j].b};
  const long m = static_cast<long>(act.nodes.size());
  C.D.resize(m);
  C.Dinv.resize(m);
  C.Ds.resize(m);
  C.Pinv.resize(m);
  // Vectors only grow (no allocation in steady state); CG works on their heads.
  if (C.x.size() < 3 * m) {
    const long cap = std::max(3 * m, 2 * static_cast<long>(C.x.size()));
    for (Eigen::VectorXd* v : {&C.x, &C.r, &C.z, &C.p, &C.ap, &C.x1, &C.x2, &C.rhs})
      v->setZero(cap);
  }
  C.history = 0;
  C.version = act.version;
}

// y = A p over the active nodes (compact; p and y hold 3m entries).
template <typename In, typename Out>
inline void apply_compact(const CompactCg& C, const std::vector<Eigen::Matrix3d>& S, const In& p,
                          Out&& y) {
  const long m = static_cast<long>(C.D.size());
  for (long k = 0; k < m; ++k)
    y.template segment<3>(3 * k).noalias() = C.D[k] * p.template segment<3>(3 * k);
  for (const auto& e : C.inner) {
    const Eigen::Vector3d t =
        S[e.k] * (p.template segment<3>(3 * e.a) - p.template segment<3>(3 * e.b));
    y.template segment<3>(3 * e.a) += t;
    y.template segment<3>(3 * e.b) -= t;
  }
}

// The same with the spring blocks in rank_one form: S u = a d (d . u) + b u.
template <typename In, typename Out>
inline void apply_compact(const CompactCg& C, const std::vector<RankOneBlock>& S, const In& p,
                          Out&& y) {
  const long m = static_cast<long>(C.D.size());
  for (long k = 0; k < m; ++k)
    y.template segment<3>(3 * k).noalias() = C.D[k] * p.template segment<3>(3 * k);
  for (const auto& e : C.inner) {
    const RankOneBlock& B = S[e.k];
    const Eigen::Vector3d u = p.template segment<3>(3 * e.a) - p.template segment<3>(3 * e.b);
    const Eigen::Vector3d t = (B.a * B.d.dot(u)) * B.d + B.b * u;
    y.template segment<3>(3 * e.a) += t;
    y.template segment<3>(3 * e.b) -= t;
  }
}

inline Eigen::Matrix3d block_matrix(const RankOneBlock& B) {
  Eigen::Matrix3d M = (B.a * B.d) * B.d.transpose();
  M.diagonal().array() += B.b;
  return M;
}

bool rank_one(const IntegratorWorkspace& ws) {
  return ws.blocks == SpringBlocks::rank_one && ws.solver == LinearSolver::cg;
}

void solve_cg_compact(const MassSpringSystem& sys, const ActiveSet& act, IntegratorWorkspace& ws) {
  CompactCg& C = ws.compact;
  if (C.version != act.version || static_cast<long>(C.local.size()) != sys.nodes())
    rebuild_compact(sys, act, C);
  const long m = static_cast<long>(act.nodes.size());
  const double h = ws.h;
  for (long k = 0; k < m; ++k) {
    const int i = act.nodes[k];
    C.D[k] =
        Eigen::Matrix3d::Identity() * (sys.mass[i] + h * sys.home_kd[i] + h * h * sys.home_ks[i]);
    C.Dinv[k] = ws.Dinv[i].inverse();  // block-Jacobi preconditioner (full diagonal block)
    C.x.segment<3>(3 * k) = ws.DV.row(i).transpose();  // warm start (head of C.x)
  }
  const bool extrapolate =
      ws.warm_start == WarmStart::extrapolated && ws.solver == LinearSolver::cg;
  if (extrapolate && C.history >= 2) C.x.head(3 * m) = 2.0 * C.x1.head(3 * m) - C.x2.head(3 * m);
  for (size_t q = 0; q < ws.contact_blocks.size(); ++q)
    C.D[C.local[ws.contact_block_node[q]]] += ws.contact_blocks[q];
  const bool r1 = rank_one(ws);
  if (r1) {
    for (const auto& e : C.held) C.D[e.a] += block_matrix(ws.SR[e.k]);
  } else {
    for (const auto& e : C.held) C.D[e.a] += ws.S[e.k];
  }
  auto x = C.x.head(3 * m), r = C.r.head(3 * m), z = C.z.head(3 * m), p = C.p.head(3 * m),
       ap = C.ap.head(3 * m);
  if (r1)
    apply_compact(C, ws.SR, x, ap);
  else
    apply_compact(C, ws.S, x, ap);
  double bnorm = 0.0;
  for (long k = 0; k < m; ++k) {
    const Eigen::Vector3d b = ws.R.row(act.nodes[k]).transpose();
    bnorm += b.squaredNorm();
    r.segment<3>(3 * k) = b - ap.segment<3>(3 * k);
    z.segment<3>(3 * k).noalias() = C.Dinv[k] * r.segment<3>(3 * k);
  }
  const bool ldlt_pre = ws.solver == LinearSolver::ldlt_frozen;
  if (ldlt_pre) z = ws.ldlt.solve(r);
  bnorm = std::sqrt(bnorm);
  p = z;
  double rz = r.dot(z);
  double rnorm = r.norm();
  // Relative to the rhs, with an absolute floor: at rest b -> 0 and a purely relative test
  // would chase rounding noise.
  const double tol = std::max(ws.cg_tolerance * bnorm, h * ws.cg_force_tolerance);
  int it = 0;
  while (rnorm > tol && it < ws.cg_max_iterations) {
    if (r1)
      apply_compact(C, ws.SR, p, ap);
    else
      apply_compact(C, ws.S, p, ap);
    const double pAp = p.dot(ap);
    if (!(pAp > 0.0)) break;
    const double alpha = rz / pAp;
    x += alpha * p;
    r -= alpha * ap;
    if (ldlt_pre) {
      z = ws.ldlt.solve(r);
    } else {
      for (long k = 0; k < m; ++k) z.segment<3>(3 * k).noalias() = C.Dinv[k] * r.segment<3>(3 * k);
    }
    const double rz_new = r.dot(z);
    rnorm = r.norm();
    p = z + (rz_new / rz) * p;
    rz = rz_new;
    ++it;
  }
  for (long k = 0; k < m; ++k) ws.DV.row(act.nodes[k]) = x.segment<3>(3 * k).transpose();
  if (extrapolate) {
    C.x2.head(3 * m) = C.x1.head(3 * m);
    C.x1.head(3 * m) = x;
    C.history = std::min(C.history + 1, 2);
  }
  ws.last.cg_iterations = it;
  ws.last.residual = bnorm > 0 ? rnorm / bnorm : rnorm;
}

// ---- The rank_one path (SpringBlocks::rank_one with CG; issue 14) --------------------------
// The same linearised backward-Euler step as the matrix path, with the data kept compact per
// active set: one pass over the active springs computes force, rhs and blocks (one sqrt and one
// division per spring: d = du / |du| and l / |du| from the same reciprocal), diagonal blocks
// are symmetric (6 numbers; the preconditioner is their closed-form inverse), the rhs and the
// CG vectors are in local node order. Differs from the matrix path at round-off only.

inline void sym_add_rank_one(Sym3& S, const RankOneBlock& B) {
  const double ax = B.a * B.d.x(), ay = B.a * B.d.y(), az = B.a * B.d.z();
  S.xx += ax * B.d.x() + B.b;
  S.yy += ay * B.d.y() + B.b;
  S.zz += az * B.d.z() + B.b;
  S.xy += ax * B.d.y();
  S.xz += ax * B.d.z();
  S.yz += ay * B.d.z();
}

inline void sym_add(Sym3& S, const Eigen::Matrix3d& M) {
  S.xx += M(0, 0);
  S.yy += M(1, 1);
  S.zz += M(2, 2);
  S.xy += M(0, 1);
  S.xz += M(0, 2);
  S.yz += M(1, 2);
}

inline Sym3 sym_inverse(const Sym3& A) {
  const double c00 = A.yy * A.zz - A.yz * A.yz, c01 = A.xz * A.yz - A.xy * A.zz,
               c02 = A.xy * A.yz - A.yy * A.xz;
  const double det = A.xx * c00 + A.xy * c01 + A.xz * c02;
  const double inv = 1.0 / det;
  return {
      c00 * inv, (A.xx * A.zz - A.xz * A.xz) * inv, (A.xx * A.yy - A.xy * A.xy) * inv, c01 * inv,
      c02 * inv, (A.xy * A.xz - A.xx * A.yz) * inv};
}

template <typename In, typename Out>
inline void sym_mul(const Sym3& S, const In& p, Out&& y) {
  const double p0 = p[0], p1 = p[1], p2 = p[2];
  y[0] = S.xx * p0 + S.xy * p1 + S.xz * p2;
  y[1] = S.xy * p0 + S.yy * p1 + S.yz * p2;
  y[2] = S.xz * p0 + S.yz * p1 + S.zz * p2;
}

// y = A p, A = blockdiag(Ds) + the inner springs' blocks (rank-one form, C.iblocks). Springs
// come in runs with the same first end (the edge order); a run's sum on that end is kept in
// registers and stored once (every y entry still receives its terms in spring order, so the
// result is bit-identical to storing after each spring; the stores and reloads were the
// product's critical path).
inline void apply_rank_one(const CompactCg& C, const double* p, double* y) {
  const long m = static_cast<long>(C.Ds.size());
  for (long k = 0; k < m; ++k) sym_mul(C.Ds[k], p + 3 * k, y + 3 * k);
  const CompactCg::InnerBlock* B = C.iblocks.data();
  const CompactCg::InnerBlock* const end = B + C.iblocks.size();
  while (B != end) {
    const int a = B->ia;
    const double* pa = p + 3 * a;
    const double pa0 = pa[0], pa1 = pa[1], pa2 = pa[2];
    double* ya = y + 3 * a;
    double ya0 = ya[0], ya1 = ya[1], ya2 = ya[2];
    for (; B != end && B->ia == a; ++B) {  // b != a: y at b never aliases the run's sum
      const double* pb = p + 3 * B->ib;
      const double u0 = pa0 - pb[0], u1 = pa1 - pb[1], u2 = pa2 - pb[2];
      const double s = B->a * (B->d0 * u0 + B->d1 * u1 + B->d2 * u2);
      const double t0 = s * B->d0 + B->b * u0, t1 = s * B->d1 + B->b * u1,
                   t2 = s * B->d2 + B->b * u2;
      ya0 += t0;
      ya1 += t1;
      ya2 += t2;
      double* yb = y + 3 * B->ib;
      yb[0] -= t0;
      yb[1] -= t1;
      yb[2] -= t2;
    }
    ya[0] = ya0;
    ya[1] = ya1;
    ya[2] = ya2;
  }
}

void backward_euler_rank_one(MassSpringSystem& sys, const ActiveSet& act, double h,
                             IntegratorWorkspace& ws) {
  CompactCg& C = ws.compact;
  if (C.version != act.version || static_cast<long>(C.local.size()) != sys.nodes())
    rebuild_compact(sys, act, C);
  const long m = static_cast<long>(act.nodes.size());
  const double h2 = h * h;
  double* b = C.rhs.data();
  // Node terms: rhs h (f - h kh v), diagonal m + h dh + h^2 kh.
  for (long k = 0; k < m; ++k) {
    const int i = act.nodes[k];
    Eigen::RowVector3d f = sys.F_ext.row(i);
    const double kh = sys.home_ks[i], dh = sys.home_kd[i];
    if (kh != 0.0 || dh != 0.0) f += kh * (sys.X_rest.row(i) - sys.X.row(i)) - dh * sys.V.row(i);
    const Eigen::RowVector3d r = h * (f - h * kh * sys.V.row(i));
    b[3 * k] = r[0];
    b[3 * k + 1] = r[1];
    b[3 * k + 2] = r[2];
    const double d = sys.mass[i] + h * dh + h2 * kh;
    C.Ds[k] = {d, d, d, 0.0, 0.0, 0.0};
  }
  // The probe's penalty on every penetrating, integrated patch node (as in backward_euler).
  ws.contact_blocks.clear();
  ws.contact_block_node.clear();
  if (sys.contact_node >= 0) {
    const Eigen::Vector3d& n = sys.contact_normal;
    for (size_t q = 0; q < sys.contact_nodes.size(); ++q) {
      const int p = sys.contact_nodes[q];
      const double d = contact_node_penetration(sys, sys.X, q);
      if (!(d > 0.0) || !act.is_active[p]) continue;
      const double kw = sys.contact_k * sys.contact_weights[q];
      const Eigen::Matrix3d Kc = -kw * (n * n.transpose());
      const Eigen::Vector3d r = -(h * kw * d) * n + (h * h) * (Kc * sys.V.row(p).transpose());
      const int k = C.local[p];
      for (int c = 0; c < 3; ++c) b[3 * k + c] += r[c];
      ws.contact_blocks.push_back(-(h * h) * Kc);
      ws.contact_block_node.push_back(p);
      sym_add(C.Ds[k], ws.contact_blocks.back());
    }
  }
  ws.contact_on = !ws.contact_blocks.empty();
  // The preconditioner's blocks start as the product's (held springs are added to both below).
  std::vector<Sym3>& P = C.Pinv;
  std::copy(C.Ds.begin(), C.Ds.begin() + m, P.begin());
  // The springs' directions first (one sqrt and one division each, independent of each other:
  // in a loop of their own they overlap instead of heading each spring's chain below; the same
  // operations on the same values, so the step is bit-identical to computing them inline).
  const double* X = sys.X.data();
  const double* V = sys.V.data();
  const auto& E = sys.springs.E;
  const size_t ns = act.springs.size();
  if (C.dirs.size() < ns) C.dirs.resize(ns + ns / 2);
  CompactCg::Direction* dir = C.dirs.data();
  for (size_t k = 0; k < ns; ++k) {
    const int s = act.springs[k];
    const double* xa = X + 3 * E(s, 0);
    const double* xb = X + 3 * E(s, 1);
    const double du0 = xa[0] - xb[0], du1 = xa[1] - xb[1], du2 = xa[2] - xb[2];
    const double len = std::sqrt(du0 * du0 + du1 * du1 + du2 * du2);
    const double il = 1.0 / len;  // inf for a zero length, never used then
    dir[k] = {du0 * il, du1 * il, du2 * il, len, il};
  }
  // One pass over the springs: force, tangent (spring_tangent's formulas with one reciprocal),
  // rhs h f1 + h^2 K dv (dv over the active ends) and the blocks a d d^T + b I.
  CompactCg::InnerBlock* ib = C.iblocks.data();
  for (size_t k = 0; k < ns; ++k) {
    const int s = act.springs[k];
    const int ga = E(s, 0), gb = E(s, 1);
    const CompactCg::Ends en = C.ends[k];
    RankOneBlock B;
    const double len = dir[k].len;
    if (!(len > 0.0)) {  // zero length: no force, no stiffness (spring_tangent)
      if (en.a >= 0 && en.b >= 0) {
        ib->d0 = ib->d1 = ib->d2 = ib->a = ib->b = 0.0;
        ++ib;
      }
      continue;
    }
    const double ks = sys.springs.ks[s], kd = sys.springs.kd[s], rest = sys.springs.rest[s];
    const double il = dir[k].il;
    const double d0 = dir[k].d0, d1 = dir[k].d1, d2 = dir[k].d2;
    const double* va = V + 3 * ga;
    const double* vb = V + 3 * gb;
    const double mag = ks * (len - rest) +
                       kd * ((va[0] - vb[0]) * d0 + (va[1] - vb[1]) * d1 + (va[2] - vb[2]) * d2);
    const double lateral = spring_lateral(ks, rest, rest * il, ws.jacobian);
    const double axial = ks - lateral;
    B.d = Eigen::Vector3d(d0, d1, d2);
    B.a = h * kd + h2 * axial;
    B.b = h2 * lateral;
    if (en.a >= 0 && en.b >= 0) {
      ib->d0 = d0, ib->d1 = d1, ib->d2 = d2, ib->a = B.a, ib->b = B.b;
      ++ib;
    }
    double w0 = 0.0, w1 = 0.0, w2 = 0.0;  // dv over the active ends
    if (en.a >= 0) w0 += va[0], w1 += va[1], w2 += va[2];
    if (en.b >= 0) w0 -= vb[0], w1 -= vb[1], w2 -= vb[2];
    const double sa = h2 * axial * (d0 * w0 + d1 * w1 + d2 * w2), sl = h2 * lateral;
    const double hm = -h * mag;
    const double r0 = hm * d0 - (sa * d0 + sl * w0), r1 = hm * d1 - (sa * d1 + sl * w1),
                 r2 = hm * d2 - (sa * d2 + sl * w2);
    if (en.a >= 0) {
      double* ba = b + 3 * en.a;
      ba[0] += r0, ba[1] += r1, ba[2] += r2;
      sym_add_rank_one(P[en.a], B);
      if (en.b < 0) sym_add_rank_one(C.Ds[en.a], B);
    }
    if (en.b >= 0) {
      double* bb = b + 3 * en.b;
      bb[0] -= r0, bb[1] -= r1, bb[2] -= r2;
      sym_add_rank_one(P[en.b], B);
      if (en.a < 0) sym_add_rank_one(C.Ds[en.b], B);
    }
  }
  for (long k = 0; k < m; ++k) P[k] = sym_inverse(P[k]);

  // Block-Jacobi preconditioned CG from the warm start (as solve_cg_compact).
  double* x = C.x.data();
  for (long k = 0; k < m; ++k) {
    const int i = act.nodes[k];
    for (int c = 0; c < 3; ++c) x[3 * k + c] = ws.DV(i, c);
  }
  const bool extrapolate = ws.warm_start == WarmStart::extrapolated;
  if (extrapolate && C.history >= 2) C.x.head(3 * m) = 2.0 * C.x1.head(3 * m) - C.x2.head(3 * m);
  double* r = C.r.data();
  double* z = C.z.data();
  double* p = C.p.data();
  double* ap = C.ap.data();
  apply_rank_one(C, x, ap);
  double bnorm = 0.0, rz = 0.0, rr = 0.0;
  for (long k = 0; k < m; ++k) {
    for (int c = 0; c < 3; ++c) {
      const long j = 3 * k + c;
      bnorm += b[j] * b[j];
      r[j] = b[j] - ap[j];
    }
    sym_mul(P[k], r + 3 * k, z + 3 * k);
  }
  const long n3 = 3 * m;
  for (long j = 0; j < n3; ++j) {
    p[j] = z[j];
    rz += r[j] * z[j];
    rr += r[j] * r[j];
  }
  bnorm = std::sqrt(bnorm);
  double rnorm = std::sqrt(rr);
  const double tol = std::max(ws.cg_tolerance * bnorm, h * ws.cg_force_tolerance);
  int it = 0;
  while (rnorm > tol && it < ws.cg_max_iterations) {
    apply_rank_one(C, p, ap);
    double pAp = 0.0;
    for (long j = 0; j < n3; ++j) pAp += p[j] * ap[j];
    if (!(pAp > 0.0)) break;
    const double alpha = rz / pAp;
    double rz_new = 0.0;
    rr = 0.0;
    for (long k = 0; k < m; ++k) {
      for (int c = 0; c < 3; ++c) {
        const long j = 3 * k + c;
        x[j] += alpha * p[j];
        r[j] -= alpha * ap[j];
        rr += r[j] * r[j];
      }
      sym_mul(P[k], r + 3 * k, z + 3 * k);
      for (int c = 0; c < 3; ++c) rz_new += r[3 * k + c] * z[3 * k + c];
    }
    rnorm = std::sqrt(rr);
    const double beta = rz_new / rz;
    for (long j = 0; j < n3; ++j) p[j] = z[j] + beta * p[j];
    rz = rz_new;
    ++it;
  }
  if (extrapolate) {
    C.x2.head(3 * m) = C.x1.head(3 * m);
    C.x1.head(3 * m) = C.x.head(3 * m);
    C.history = std::min(C.history + 1, 2);
  }
  ws.last.cg_iterations = it;
  ws.last.residual = bnorm > 0 ? rnorm / bnorm : rnorm;
  for (long k = 0; k < m; ++k) {
    const int i = act.nodes[k];
    for (int c = 0; c < 3; ++c) {
      ws.DV(i, c) = x[3 * k + c];
      sys.V(i, c) += x[3 * k + c];
      sys.X(i, c) += h * sys.V(i, c);
    }
  }
}

void backward_euler(MassSpringSystem& sys, const ActiveSet& act, double h,
                    IntegratorWorkspace& ws) {
  const long n = sys.nodes();
  ws.h = h;
  ensure(ws.R, n);
  ensure(ws.DV, n);
  if (rank_one(ws)) {
    backward_euler_rank_one(sys, act, h, ws);
    return;
  }
  if (ws.Dinv.size() < static_cast<size_t>(n)) ws.Dinv.resize(n);
  const bool r1 = rank_one(ws);
  if (r1) {
    if (ws.SR.size() < act.springs.size())
      ws.SR.resize(act.springs.size() + act.springs.size() / 2);
  } else if (ws.S.size() < act.springs.size()) {
    ws.S.resize(act.springs.size() + act.springs.size() / 2);
  }

  // The rhs b = h (f0 + h K v0) (held nodes count as v = 0 in K v0) and the diagonal blocks,
  // node terms first, then one fused pass over the springs: force, Jacobian, rhs, blocks.
  for (int i : act.nodes) {
    Eigen::RowVector3d f = sys.F_ext.row(i);
    const double kh = sys.home_ks[i], dh = sys.home_kd[i];
    if (kh != 0.0 || dh != 0.0) f += kh * (sys.X_rest.row(i) - sys.X.row(i)) - dh * sys.V.row(i);
    ws.R.row(i) = h * (f - h * kh * sys.V.row(i));
    ws.Dinv[i] = Eigen::Matrix3d::Identity() * (sys.mass[i] + h * dh + h * h * kh);
  }
  // The probe's penalty on every penetrating, integrated patch node: force -k w d n, Jacobian
  // K = -k w n n^T (contact_node_penetration is the same function the force sum uses).
  ws.contact_blocks.clear();
  ws.contact_block_node.clear();
  if (sys.contact_node >= 0) {
    const Eigen::Matrix3d nn = sys.contact_normal * sys.contact_normal.transpose();
    for (size_t q = 0; q < sys.contact_nodes.size(); ++q) {
      const int p = sys.contact_nodes[q];
      const double d = contact_node_penetration(sys, sys.X, q);
      if (!(d > 0.0) || !act.is_active[p]) continue;
      const double kw = sys.contact_k * sys.contact_weights[q];
      const Eigen::Matrix3d Kc = -kw * nn;
      ws.R.row(p) -= (h * kw * d) * sys.contact_normal.transpose();
      ws.R.row(p) += ((h * h) * (Kc * sys.V.row(p).transpose())).transpose();
      ws.contact_blocks.push_back(-(h * h) * Kc);
      ws.contact_block_node.push_back(p);
      ws.Dinv[p] += ws.contact_blocks.back();
    }
  }
  ws.contact_on = !ws.contact_blocks.empty();
  const double h2 = h * h;
  for (size_t k = 0; r1 && k < act.springs.size(); ++k) {
    // The rank_one form: S = a P + b I with a = h kd + h^2 (axial - lateral), b = h^2 lateral,
    // and K v = -((axial - lateral) d (d . v) + lateral v).
    const int s = act.springs[k];
    const int a = sys.springs.E(s, 0), b = sys.springs.E(s, 1);
    const bool aa = act.is_active[a], ba = act.is_active[b];
    SpringTangent t;
    spring_tangent(sys.X.row(a).transpose(), sys.X.row(b).transpose(), sys.V.row(a).transpose(),
                   sys.V.row(b).transpose(), sys.springs.ks[s], sys.springs.kd[s],
                   sys.springs.rest[s], ws.jacobian, t);
    RankOneBlock& B = ws.SR[k];
    const double axial = t.axial - t.lateral;
    B.d = t.d;
    B.a = h * t.kd + h2 * axial;
    B.b = h2 * t.lateral;
    Eigen::Vector3d dv = Eigen::Vector3d::Zero();
    if (aa) dv += sys.V.row(a).transpose();
    if (ba) dv -= sys.V.row(b).transpose();
    const Eigen::Vector3d r = h * t.f1 - h2 * ((axial * t.d.dot(dv)) * t.d + t.lateral * dv);
    if (!aa && !ba) continue;
    const Eigen::Matrix3d Sk = block_matrix(B);
    if (aa) {
      ws.R.row(a) += r.transpose();
      ws.Dinv[a] += Sk;
    }
    if (ba) {
      ws.R.row(b) -= r.transpose();
      ws.Dinv[b] += Sk;
    }
  }
  for (size_t k = 0; !r1 && k < act.springs.size(); ++k) {
    const int s = act.springs[k];
    const int a = sys.springs.E(s, 0), b = sys.springs.E(s, 1);
    const bool aa = act.is_active[a], ba = act.is_active[b];
    const Eigen::Vector3d du = (sys.X.row(a) - sys.X.row(b)).transpose();
    const double len = du.norm();
    if (len <= 0.0) {
      ws.S[k].setZero();
      continue;
    }
    Eigen::Vector3d f1;
    Eigen::Matrix3d Kx, Kv;
    spring_eval(sys.X.row(a).transpose(), sys.X.row(b).transpose(), sys.V.row(a).transpose(),
                sys.V.row(b).transpose(), sys.springs.ks[s], sys.springs.kd[s], sys.springs.rest[s],
                ws.jacobian, f1, Kx, Kv);
    ws.S[k] = -h * Kv - h2 * Kx;  // -(h Kv + h^2 Kx)
    Eigen::Vector3d dv = Eigen::Vector3d::Zero();
    if (aa) dv += sys.V.row(a).transpose();
    if (ba) dv -= sys.V.row(b).transpose();
    const Eigen::Vector3d r = h * f1 + h2 * (Kx * dv);
    if (aa) {
      ws.R.row(a) += r.transpose();
      ws.Dinv[a] += ws.S[k];
    }
    if (ba) {
      ws.R.row(b) -= r.transpose();
      ws.Dinv[b] += ws.S[k];
    }
  }

  if (ws.solver == LinearSolver::cg || ws.solver == LinearSolver::ldlt_frozen) {
    if (ws.solver == LinearSolver::ldlt_frozen) {
      // Reuse a factorisation: A at the time of factorisation preconditions CG on the current A
      // (a stale A used as the solve itself is unstable: at rest it has no lateral stiffness).
      const int contact_key = ws.contact_on ? sys.contact_node : -1;
      if (ws.factor_version != act.version || ws.factor_contact != contact_key ||
          ws.factor_h != h || ws.factor_contact_k != (ws.contact_on ? sys.contact_k : 0.0))
        factor_A(sys, act, h, ws);
    }
    solve_cg_compact(sys, act, ws);
  } else {
    // Exact linearised backward Euler: assemble and factorise every step.
    factor_A(sys, act, h, ws);
    const long m = static_cast<long>(act.nodes.size());
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
