// Finite-difference checks of the Voigt spring force (Eq 5.3) and of the Jacobian blocks used by
// backward Euler.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "engine/models/mass_spring.hpp"
#include "engine/solvers/integrators.hpp"

using namespace palplab::engine;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {
// A spring's elastic energy E = ks/2 (|du| - l)^2; the force must be -dE/dx1.
double energy(const Vector3d& x1, const Vector3d& x2, double ks, double l) {
  const double e = (x1 - x2).norm() - l;
  return 0.5 * ks * e * e;
}
}  // namespace

TEST(Springs, ForceIsMinusEnergyGradient) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    Vector3d x1(U(rng), U(rng), U(rng)), x2(U(rng), U(rng), U(rng));
    const double ks = 50.0 + 100 * std::abs(U(rng)), l = 0.3 + std::abs(U(rng));
    const Vector3d f = spring_force(x1, x2, Vector3d::Zero(), Vector3d::Zero(), ks, 0.0, l);
    const double eps = 1e-6;
    for (int k = 0; k < 3; ++k) {
      Vector3d a = x1, b = x1;
      a[k] += eps;
      b[k] -= eps;
      const double g = (energy(a, x2, ks, l) - energy(b, x2, ks, l)) / (2 * eps);
      EXPECT_NEAR(f[k], -g, 1e-6 * std::max(1.0, std::abs(g)));
    }
  }
}

TEST(Springs, DampingAlongSpringOnly) {
  // Relative velocity perpendicular to the spring produces no damping force.
  const Vector3d x1(1, 0, 0), x2(0, 0, 0);
  Vector3d f = spring_force(x1, x2, Vector3d(0, 3, 0), Vector3d::Zero(), 0.0, 2.0, 1.0);
  EXPECT_NEAR(f.norm(), 0.0, 1e-15);
  f = spring_force(x1, x2, Vector3d(3, 0, 0), Vector3d::Zero(), 0.0, 2.0, 1.0);
  EXPECT_NEAR(f[0], -6.0, 1e-12);  // F1 = -kd (dv.d) d
  // Newton's third law at the system level.
  MassSpringSystem sys;
  sys.X.resize(2, 3);
  sys.X << 0, 0, 0, 1.2, 0.1, -0.3;
  sys.V.resize(2, 3);
  sys.V << 0.1, 0.2, 0.3, -0.5, 0.1, 0.0;
  sys.X_rest = sys.X;
  sys.F_ext.setZero(2, 3);
  sys.mass.setOnes(2);
  sys.home_ks.setZero(2);
  sys.home_kd.setZero(2);
  RowMatX2i E(1, 2);
  E << 0, 1;
  sys.springs = springs_from_edges(sys.X, E, 10.0, 0.5);
  sys.springs.rest[0] = 1.0;
  RowMatX3d F;
  compute_forces(sys, sys.X, sys.V, F);
  EXPECT_NEAR((F.row(0) + F.row(1)).norm(), 0.0, 1e-14);
  EXPECT_GT(F.row(0).norm(), 1.0);
}

TEST(Springs, JacobianMatchesFiniteDifferences) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    Vector3d x1(U(rng), U(rng), U(rng)), x2(U(rng), U(rng), U(rng));
    Vector3d v1(U(rng), U(rng), U(rng)), v2(U(rng), U(rng), U(rng));
    const double ks = 80.0, kd = 3.0;
    // Alternate stretched and compressed springs.
    const double l = (x1 - x2).norm() * (trial % 2 ? 1.5 : 0.6);
    Matrix3d Kx, Kv;
    Vector3d f1;
    spring_eval(x1, x2, v1, v2, ks, kd, l, SpringJacobian::exact, f1, Kx, Kv);
    EXPECT_NEAR((f1 - spring_force(x1, x2, v1, v2, ks, kd, l)).norm(), 0.0, 1e-12 * ks);
    const double eps = 1e-6;
    for (int k = 0; k < 3; ++k) {
      Vector3d a = x1, b = x1;
      a[k] += eps;
      b[k] -= eps;
      // Elastic part: compare at zero relative velocity (the damping's position derivative is
      // deliberately not in Kx, and vanishes there).
      Vector3d fd =
          (spring_force(a, x2, v1, v1, ks, kd, l) - spring_force(b, x2, v1, v1, ks, kd, l)) /
          (2 * eps);
      for (int r = 0; r < 3; ++r) EXPECT_NEAR(Kx(r, k), fd[r], 1e-5 * ks);
      // d/dx2 = -Kx
      a = x2;
      b = x2;
      a[k] += eps;
      b[k] -= eps;
      fd = (spring_force(x1, a, v1, v1, ks, kd, l) - spring_force(x1, b, v1, v1, ks, kd, l)) /
           (2 * eps);
      for (int r = 0; r < 3; ++r) EXPECT_NEAR(-Kx(r, k), fd[r], 1e-5 * ks);
      // Velocity Jacobian, exact for any state.
      Vector3d va = v1, vb = v1;
      va[k] += eps;
      vb[k] -= eps;
      fd = (spring_force(x1, x2, va, v2, ks, kd, l) - spring_force(x1, x2, vb, v2, ks, kd, l)) /
           (2 * eps);
      for (int r = 0; r < 3; ++r) EXPECT_NEAR(Kv(r, k), fd[r], 1e-6 * kd);
    }
    // The PSD projection only changes compressed springs, and makes -Kx PSD.
    Matrix3d Kp, Kvp;
    spring_eval(x1, x2, v1, v2, ks, kd, l, SpringJacobian::definite, f1, Kp, Kvp);
    Eigen::SelfAdjointEigenSolver<Matrix3d> es(-Kp);
    EXPECT_GE(es.eigenvalues().minCoeff(), -1e-9);
    if (trial % 2 == 0) {
      EXPECT_NEAR((Kp - Kx).norm(), 0.0, 1e-12);  // stretched: unchanged
    } else {
      // Compressed: exactly the negative lateral term ks(1 - l/|du|)(I - P) is dropped.
      const Vector3d d = (x1 - x2).normalized();
      const double lateral = ks * (1.0 - l / (x1 - x2).norm());
      ASSERT_LT(lateral, 0.0);
      EXPECT_NEAR((Kp - Kx - lateral * (Matrix3d::Identity() - d * d.transpose())).norm(), 0.0,
                  1e-9 * ks);
    }
  }
}

TEST(Springs, UniqueEdgesOfTetAndTriangles) {
  RowMatX4i T(1, 4);
  T << 0, 1, 2, 3;
  EXPECT_EQ(unique_edges(T).rows(), 6);
  RowMatX3i F(4, 3);
  F << 0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2;
  const RowMatX2i E = unique_edges(F);
  EXPECT_EQ(E.rows(), 6);
  for (long e = 0; e < E.rows(); ++e) EXPECT_LT(E(e, 0), E(e, 1));
}

TEST(Springs, ContactPenaltyForceAndItsJacobian) {
  // One node pushed by the device along -n: force -k d n while the penetration d > 0.
  MassSpringSystem s;
  s.X.resize(1, 3);
  s.X << 0.01, 0.02, -0.001;
  s.V.setZero(1, 3);
  s.X_rest = s.X;
  s.F_ext.setZero(1, 3);
  s.mass.setOnes(1);
  s.home_ks.setZero(1);
  s.home_kd.setZero(1);
  s.contact_node = 0;
  s.contact_nodes = {0};
  s.contact_weights = {1.0};
  s.contact_point = Vector3d(0.011, 0.019, -0.004);
  s.contact_normal = Vector3d(0.2, -0.1, 1.0).normalized();
  s.contact_k = 2000.0;
  const double d = contact_penetration(s, s.X);
  EXPECT_NEAR(d, (s.X.row(0).transpose() - s.contact_point).dot(s.contact_normal), 1e-15);
  ASSERT_GT(d, 0.0);
  RowMatX3d F;
  compute_forces(s, s.X, s.V, F);
  EXPECT_NEAR((F.row(0).transpose() + 2000.0 * d * s.contact_normal).norm(), 0.0, 1e-12);
  // dF/dx = -k n n^T (what backward Euler uses), by central differences.
  const Matrix3d K = -2000.0 * s.contact_normal * s.contact_normal.transpose();
  for (int k = 0; k < 3; ++k) {
    RowMatX3d Xp = s.X, Xm = s.X, Fp, Fm;
    Xp(0, k) += 1e-7;
    Xm(0, k) -= 1e-7;
    compute_forces(s, Xp, s.V, Fp);
    compute_forces(s, Xm, s.V, Fm);
    const Vector3d fd = (Fp.row(0) - Fm.row(0)).transpose() / 2e-7;
    for (int r = 0; r < 3; ++r) EXPECT_NEAR(K(r, k), fd[r], 1e-5);
  }
  // No pull: the device above the surface exerts nothing.
  s.contact_point = s.X.row(0).transpose() + 0.001 * s.contact_normal;
  compute_forces(s, s.X, s.V, F);
  EXPECT_EQ(F.row(0).norm(), 0.0);
}

TEST(Springs, BackwardEulerSolvesWithTheFiniteDifferenceJacobian) {
  // The integrator's own path: one linearised backward-Euler step (exact Jacobian, LDLT) must
  // equal the solve of (M - h^2 K) dv = h f0 with K from central differences of compute_forces
  // (springs, home springs and a two-node contact patch), at v = 0 with no damping.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-1, 1);
  MassSpringSystem s;
  const int n = 6;
  s.X_rest.resize(n, 3);
  for (int i = 0; i < n; ++i) s.X_rest.row(i) << 0.02 * U(rng), 0.02 * U(rng), 0.02 * U(rng);
  RowMatX2i E(9, 2);
  E << 0, 1, 0, 2, 1, 2, 1, 3, 2, 3, 3, 4, 2, 4, 4, 5, 3, 5;
  s.springs = springs_from_edges(s.X_rest, E, 150.0, 0.0);
  s.X = s.X_rest;
  for (int i = 0; i < n; ++i) s.X.row(i) += 0.003 * Eigen::RowVector3d(U(rng), U(rng), U(rng));
  s.V.setZero(n, 3);
  s.F_ext.setZero(n, 3);
  s.mass = Eigen::VectorXd::Constant(n, 0.002);
  s.home_ks = Eigen::VectorXd::Constant(n, 20.0);
  s.home_kd.setZero(n);
  s.fixed.assign(n, 0);
  s.contact_node = 4;
  s.contact_nodes = {4, 5};
  s.contact_weights = {0.7, 0.3};
  s.contact_normal = Vector3d(0.3, 0.1, 1.0).normalized();
  s.contact_point = s.X.row(4).transpose() - 0.002 * s.contact_normal;
  s.contact_k = 900.0;
  build_adjacency(s);
  ASSERT_GT(contact_node_penetration(s, s.X, 0), 0.0);
  ASSERT_GT(contact_node_penetration(s, s.X, 1), 0.0);

  const double h = 1e-3;
  RowMatX3d F0;
  compute_forces(s, s.X, s.V, F0);
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  const double eps = 1e-7;
  for (int j = 0; j < 3 * n; ++j) {
    RowMatX3d Xp = s.X, Xm = s.X, Fp, Fm;
    Xp(j / 3, j % 3) += eps;
    Xm(j / 3, j % 3) -= eps;
    compute_forces(s, Xp, s.V, Fp);
    compute_forces(s, Xm, s.V, Fm);
    for (int i = 0; i < 3 * n; ++i)
      A(i, j) = -h * h * (Fp(i / 3, i % 3) - Fm(i / 3, i % 3)) / (2 * eps);
  }
  Eigen::VectorXd b(3 * n);
  for (int i = 0; i < 3 * n; ++i) {
    A(i, i) += s.mass[i / 3];
    b[i] = h * F0(i / 3, i % 3);
  }
  const Eigen::VectorXd dv = A.partialPivLu().solve(b);

  ActiveSet act;
  activate_all(s, act);
  IntegratorWorkspace ws;
  ws.solver = LinearSolver::ldlt_refactor;
  ws.jacobian = SpringJacobian::exact;
  MassSpringSystem stepped = s;
  integrate(stepped, act, h, Integrator::backward_euler, ws);
  for (int i = 0; i < 3 * n; ++i)
    EXPECT_NEAR(stepped.V(i / 3, i % 3), dv[i], 1e-7 * dv.cwiseAbs().maxCoeff()) << i;
}
