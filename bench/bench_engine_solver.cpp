// Backward Euler's linear solve on the whole tetrahedral Model-C (2490 nodes, 15233 springs,
// no sleeping, no scope): matrix-free warm-started block-Jacobi CG vs sparse LDLT refactorised
// every step vs an LDLT factorisation reused across steps as the preconditioner of CG (a stale
// factorisation used as the solve itself diverges: at rest A has no lateral spring stiffness).
// Same press (a 5 N force on one node
// for 0.3 s, then released for 0.2 s), h = 1 ms; error against LDLT-refactor (the exact
// linearised backward Euler). Also symplectic Euler and RK4 at the same h (stability).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "engine/haptics/clock.hpp"
#include "engine/mesh/generate.hpp"
#include "engine/mesh/tet_mesh.hpp"
#include "engine/mesh/unique_edges.hpp"
#include "engine/solvers/integrators.hpp"

using namespace palplab;
using namespace palplab::engine;
using Clock = std::chrono::steady_clock;

namespace {

MassSpringSystem model_c() {
  const mesh::TetMesh tm = mesh::generate_model_c(0, 2489);
  MassSpringSystem s;
  const long n = tm.V.rows();
  s.X_rest = tm.V;
  s.X = tm.V;
  s.V.setZero(n, 3);
  s.F_ext.setZero(n, 3);
  Eigen::VectorXd vol = Eigen::VectorXd::Zero(n);
  for (long t = 0; t < tm.T.rows(); ++t)
    for (int k = 0; k < 4; ++k) vol[tm.T(t, k)] += tm.volume[t] / 4.0;
  s.mass = vol * (0.8 / vol.sum());  // 0.8 kg, as prototype C
  s.home_ks = Eigen::VectorXd::Constant(n, 150.0);
  s.home_kd = Eigen::VectorXd::Constant(n, 0.1);
  s.fixed.assign(n, 0);
  s.springs = springs_from_edges(tm.V, mesh::unique_edges(tm.T), 150.0, 0.15);
  build_adjacency(s);
  return s;
}

struct Result {
  double median_us = 0, max_err = 0;
  int mean_iters = 0;
  bool finite = true;
  RowMatX3d X_end;
  std::vector<RowMatX3d> traj;
};

Result run(Integrator method, LinearSolver solver, const std::vector<RowMatX3d>* ref) {
  MassSpringSystem s = model_c();
  ActiveSet act;
  activate_all(s, act);
  IntegratorWorkspace ws;
  ws.solver = solver;
  ws.cg_tolerance = 1e-6;
  ws.cg_force_tolerance = 1e-6;
  const int node = 1200;
  const Eigen::Vector3d dir =
      (s.X_rest.row(node) - s.X_rest.colwise().mean()).normalized().transpose();
  Result r;
  std::vector<double> us;
  long iters = 0;
  for (int k = 0; k < 500; ++k) {
    s.F_ext.row(node) = (k < 300 ? -5.0 : 0.0) * dir.transpose();
    const auto t0 = Clock::now();
    integrate(s, act, 1e-3, method, ws);
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
    iters += ws.last.cg_iterations;
    if (!std::isfinite(s.X.squaredNorm())) {
      r.finite = false;
      break;
    }
    if (!ref) r.traj.push_back(s.X);
    if (ref && k % 10 == 0)
      r.max_err = std::max(r.max_err, ((*ref)[k] - s.X).rowwise().norm().maxCoeff());
  }
  r.median_us = engine::median(us);
  r.mean_iters = static_cast<int>(iters / 500);
  return r;
}

}  // namespace

int main() {
  const Result ref = run(Integrator::backward_euler, LinearSolver::ldlt_refactor, nullptr);
  std::printf("Model-C whole model, h = 1 ms, 5 N press 0.3 s + 0.2 s release (500 steps)\n");
  std::printf("%-34s %12s %10s %12s %18s\n", "method", "median/step", "vs LDLT", "CG iters",
              "max |x - x_ref| (m)");
  std::printf("%-34s %10.1fus %9.2fx %12s %18s\n", "backward Euler, LDLT refactor (ref)",
              ref.median_us, 1.0, "-", "0");
  const struct {
    const char* name;
    Integrator m;
    LinearSolver s;
  } rows[] = {
      {"backward Euler, frozen LDLT + PCG", Integrator::backward_euler, LinearSolver::ldlt_frozen},
      {"backward Euler, CG warm-started", Integrator::backward_euler, LinearSolver::cg},
      {"symplectic Euler", Integrator::symplectic_euler, LinearSolver::cg},
      {"RK4", Integrator::rk4, LinearSolver::cg}};
  for (const auto& row : rows) {
    const Result r = run(row.m, row.s, &ref.traj);
    if (!r.finite) {
      std::printf("%-34s %10.1fus %9.2fx %12s %18s\n", row.name, r.median_us,
                  ref.median_us / r.median_us, "-", "DIVERGED (NaN)");
      continue;
    }
    char it[16];
    std::snprintf(it, sizeof it, "%d", r.mean_iters);
    std::printf("%-34s %10.1fus %9.2fx %12s %18.3e\n", row.name, r.median_us,
                ref.median_us / r.median_us, row.m == Integrator::backward_euler ? it : "-",
                r.max_err);
  }
  return 0;
}
