// The linear exterior of prototype C's scope (engine/solvers/far_field.hpp): g must be the
// static response of the model that compute_forces evaluates (the force sum the integrator
// uses), to first order in the load.
#include <gtest/gtest.h>

#include "engine/solvers/far_field.hpp"

using namespace palplab::engine;

namespace {

// A 4x4x4 lattice (1 cm spacing) with springs to every neighbour within a cube diagonal (a rigid
// framework), the bottom layer fixed, a support spring on the top layer.
MassSpringSystem lattice() {
  const int n = 4;
  const double a = 0.01;
  MassSpringSystem s;
  s.X_rest.resize(n * n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) s.X_rest.row((i * n + j) * n + k) << i * a, j * a, k * a;
  // Slightly irregular, so that no spring direction is special.
  for (long v = 0; v < s.X_rest.rows(); ++v)
    s.X_rest.row(v) +=
        0.1 * a * Eigen::RowVector3d(std::sin(3.1 * v), std::cos(1.7 * v), std::sin(0.7 * v + 1.0));
  std::vector<std::pair<int, int>> e;
  for (int p = 0; p < n * n * n; ++p)
    for (int q = p + 1; q < n * n * n; ++q) {
      const int di = std::abs(p / (n * n) - q / (n * n)), dj = std::abs((p / n) % n - (q / n) % n),
                dk = std::abs(p % n - q % n);
      if (di <= 1 && dj <= 1 && dk <= 1) e.emplace_back(p, q);
    }
  RowMatX2i E(e.size(), 2);
  for (size_t k = 0; k < e.size(); ++k) E.row(k) << e[k].first, e[k].second;
  s.springs = springs_from_edges(s.X_rest, E, 300.0, 0.0);
  for (long k = 0; k < s.springs.size(); ++k) s.springs.ks[k] *= 1.0 + 0.5 * std::sin(2.3 * k);
  s.X = s.X_rest;
  s.V.setZero(s.X.rows(), 3);
  s.F_ext.setZero(s.X.rows(), 3);
  s.mass = Eigen::VectorXd::Constant(s.X.rows(), 1e-3);
  s.home_ks = Eigen::VectorXd::Zero(s.X.rows());
  s.home_kd = Eigen::VectorXd::Zero(s.X.rows());
  s.fixed.assign(s.X.rows(), 0);
  for (long v = 0; v < s.X.rows(); ++v) {
    if (v % n == 0) s.fixed[v] = 1;
    if (v % n == n - 1) s.home_ks[v] = 50.0;
  }
  build_adjacency(s);
  return s;
}

}  // namespace

TEST(FarField, DisplacementIsTheStaticResponseOfTheForcesTheIntegratorSums) {
  MassSpringSystem s = lattice();
  FarField ff;
  far_field_build(s, ff);
  ASSERT_TRUE(ff.ready());
  // A unit load spread over three top nodes, pushing along a slanted direction.
  const std::vector<int> patch = {3, 7, 19};
  const std::vector<double> w = {0.5, 0.3, 0.2};
  const Eigen::Vector3d dir = Eigen::Vector3d(0.3, -0.2, -1.0).normalized();
  far_field_solve(ff, patch, w, dir);
  // The equilibrium residual at X_rest + load g: zero to first order, so it must shrink with the
  // square of the load (a wrong stiffness leaves a residual linear in the load).
  double residual[2];
  const double loads[2] = {1e-2, 1e-3};  // N
  for (int q = 0; q < 2; ++q) {
    const double load = loads[q];
    s.X = s.X_rest;
    for (long v = 0; v < s.X.rows(); ++v)
      if (ff.dof[v] >= 0) s.X.row(v) += load * ff.g.segment<3>(ff.dof[v]).transpose();
    RowMatX3d F;
    compute_forces(s, s.X, s.V, F);
    for (size_t k = 0; k < patch.size(); ++k) F.row(patch[k]) += load * w[k] * dir.transpose();
    residual[q] = 0.0;
    for (long v = 0; v < s.X.rows(); ++v)
      if (!s.fixed[v]) residual[q] = std::max(residual[q], F.row(v).norm());
    std::printf("load %.0e N: largest displacement %.2e m, residual %.2e N\n", load,
                load * ff.g.cwiseAbs().maxCoeff(), residual[q]);
  }
  EXPECT_GT(ff.g.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_LT(residual[1], 1e-3 * loads[1]);
  EXPECT_GT(residual[0] / residual[1], 50.0);  // quadratic: 100
  // Fixed nodes have no dof; a load on a fixed node alone gives no displacement.
  EXPECT_EQ(ff.dof[0], -1);
  far_field_solve(ff, {0}, {1.0}, dir);
  EXPECT_EQ(ff.g.cwiseAbs().maxCoeff(), 0.0);
}

TEST(FarField, UnsupportedPartIsAnError) {
  MassSpringSystem s = lattice();
  s.fixed.assign(s.X.rows(), 0);
  s.home_ks.setZero();
  FarField ff;
  EXPECT_THROW(far_field_build(s, ff), std::runtime_error);
}
