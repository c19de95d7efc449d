// Integrators against the analytic damped oscillator (convergence order of each method), and a
// stiff case where symplectic Euler diverges while backward Euler stays bounded.
#include <gtest/gtest.h>

#include <cmath>

#include "engine/solvers/integrators.hpp"

using namespace palplab::engine;

namespace {

// Node 0 pinned at the origin, node 1 on the x axis at rest length l + a0: motion stays on the
// axis, so m x'' = -k x - c x' exactly (x = stretch).
MassSpringSystem oscillator(double m, double k, double c, double l, double a0) {
  MassSpringSystem s;
  s.X.resize(2, 3);
  s.X << 0, 0, 0, l + a0, 0, 0;
  s.V.setZero(2, 3);
  s.X_rest = s.X;
  s.X_rest(1, 0) = l;
  s.F_ext.setZero(2, 3);
  s.mass = Eigen::Vector2d(1.0, m);
  s.home_ks.setZero(2);
  s.home_kd.setZero(2);
  s.fixed = {1, 0};
  RowMatX2i E(1, 2);
  E << 0, 1;
  s.springs = springs_from_edges(s.X, E, k, c);
  s.springs.rest[0] = l;
  build_adjacency(s);
  return s;
}

double analytic(double m, double k, double c, double a0, double t) {
  const double w0 = std::sqrt(k / m), z = c / (2 * std::sqrt(k * m)),
               wd = w0 * std::sqrt(1 - z * z);
  return std::exp(-z * w0 * t) * (a0 * std::cos(wd * t) + z * w0 * a0 / wd * std::sin(wd * t));
}

double run_error(Integrator method, LinearSolver solver, double h, double T = 1.0) {
  const double m = 0.5, k = 50.0, c = 0.8, l = 0.1, a0 = 0.02;
  MassSpringSystem s = oscillator(m, k, c, l, a0);
  ActiveSet act;
  activate_all(s, act);
  IntegratorWorkspace ws;
  ws.solver = solver;
  ws.cg_tolerance = 1e-13;
  const int n = static_cast<int>(std::lround(T / h));
  for (int i = 0; i < n; ++i) integrate(s, act, h, method, ws);
  EXPECT_NEAR(s.X(1, 1), 0.0, 1e-15);
  return std::abs((s.X(1, 0) - l) - analytic(m, k, c, a0, n * h));
}

}  // namespace

TEST(Integrators, SymplecticEulerFirstOrder) {
  const double e1 = run_error(Integrator::symplectic_euler, LinearSolver::cg, 2e-3);
  const double e2 = run_error(Integrator::symplectic_euler, LinearSolver::cg, 1e-3);
  const double e3 = run_error(Integrator::symplectic_euler, LinearSolver::cg, 5e-4);
  EXPECT_LT(e1, 2e-3);
  EXPECT_NEAR(e1 / e2, 2.0, 0.25);
  EXPECT_NEAR(e2 / e3, 2.0, 0.15);
}

TEST(Integrators, BackwardEulerFirstOrderWithEverySolver) {
  for (LinearSolver s : {LinearSolver::cg, LinearSolver::ldlt_refactor}) {
    const double e1 = run_error(Integrator::backward_euler, s, 2e-3);
    const double e2 = run_error(Integrator::backward_euler, s, 1e-3);
    const double e3 = run_error(Integrator::backward_euler, s, 5e-4);
    EXPECT_NEAR(e1 / e2, 2.0, 0.25) << to_string(s);
    EXPECT_NEAR(e2 / e3, 2.0, 0.15) << to_string(s);
  }
  // On this linear problem the frozen factorisation is exact too, and all solvers agree.
  const double a = run_error(Integrator::backward_euler, LinearSolver::cg, 1e-3);
  const double b = run_error(Integrator::backward_euler, LinearSolver::ldlt_refactor, 1e-3);
  const double c = run_error(Integrator::backward_euler, LinearSolver::ldlt_frozen, 1e-3);
  EXPECT_NEAR(a, b, 1e-10);
  EXPECT_NEAR(b, c, 1e-10);
}

TEST(Integrators, Rk4FourthOrder) {
  const double e1 = run_error(Integrator::rk4, LinearSolver::cg, 8e-3);
  const double e2 = run_error(Integrator::rk4, LinearSolver::cg, 4e-3);
  const double e3 = run_error(Integrator::rk4, LinearSolver::cg, 2e-3);
  EXPECT_LT(e2, 1e-8);
  EXPECT_NEAR(e1 / e2, 16.0, 2.0);
  EXPECT_NEAR(e2 / e3, 16.0, 2.0);
}

namespace {
// A stiff tet (3 nodes pinned) with its free apex displaced: omega = sqrt(k/m) ~ 1e4 rad/s, so
// h = 1 ms is far beyond symplectic Euler's limit h < 2/omega.
MassSpringSystem stiff_tet() {
  MassSpringSystem s;
  s.X_rest.resize(4, 3);
  s.X_rest << 0, 0, 0, 0.01, 0, 0, 0, 0.01, 0, 0.003, 0.003, 0.01;
  RowMatX4i T(1, 4);
  T << 0, 1, 2, 3;
  s.springs = springs_from_edges(s.X_rest, unique_edges(T), 2.0e3, 0.05);
  s.X = s.X_rest;
  s.X.row(3) += Eigen::RowVector3d(0.002, -0.001, 0.003);
  s.V.setZero(4, 3);
  s.F_ext.setZero(4, 3);
  s.mass.setConstant(4, 1e-4);
  s.home_ks.setZero(4);
  s.home_kd.setZero(4);
  s.fixed = {1, 1, 1, 0};
  build_adjacency(s);
  return s;
}
}  // namespace

TEST(Integrators, StiffSymplecticDivergesBackwardEulerReturnsToRest) {
  for (int solver = 0; solver < 2; ++solver) {
    MassSpringSystem se = stiff_tet(), be = stiff_tet();
    ActiveSet act;
    activate_all(se, act);
    IntegratorWorkspace w1, w2;
    w2.solver = solver ? LinearSolver::ldlt_refactor : LinearSolver::cg;
    double max_be = 0.0;
    for (int i = 0; i < 2000; ++i) {
      integrate(be, act, 1e-3, Integrator::backward_euler, w2);
      max_be = std::max(max_be, (be.X.row(3) - be.X_rest.row(3)).norm());
    }
    for (int i = 0; i < 200; ++i) integrate(se, act, 1e-3, Integrator::symplectic_euler, w1);
    const double se_err = (se.X.row(3) - se.X_rest.row(3)).norm();
    EXPECT_TRUE(!std::isfinite(se_err) || se_err > 1.0) << se_err;  // blown up
    EXPECT_LT(max_be, 0.0040);  // never beyond the initial displacement (|d0| = 3.7 mm)
    EXPECT_LT((be.X.row(3) - be.X_rest.row(3)).norm(), 1e-6);  // back at rest after 2 s
    EXPECT_LT(be.V.row(3).norm(), 1e-5);
  }
}

TEST(Integrators, HeldNodesDoNotMove) {
  MassSpringSystem s = stiff_tet();
  ActiveSet act;
  activate_all(s, act);
  IntegratorWorkspace ws;
  const RowMatX3d X0 = s.X;
  for (Integrator m : {Integrator::symplectic_euler, Integrator::backward_euler, Integrator::rk4})
    for (int i = 0; i < 3; ++i) integrate(s, act, 1e-5, m, ws);
  EXPECT_EQ((s.X.topRows(3) - X0.topRows(3)).norm(), 0.0);
  EXPECT_GT((s.X.row(3) - X0.row(3)).norm(), 0.0);
}
