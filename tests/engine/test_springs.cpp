// Finite-difference checks of the Voigt spring force (Eq 5.3) and of the Jacobian blocks used by
// backward Euler.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "engine/models/mass_spring.hpp"

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
    spring_jacobian(x1, x2, ks, kd, l, false, Kx, Kv);
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
    spring_jacobian(x1, x2, ks, kd, l, true, Kp, Kvp);
    Eigen::SelfAdjointEigenSolver<Matrix3d> es(-Kp);
    EXPECT_GE(es.eigenvalues().minCoeff(), -1e-9);
    if (trial % 2 == 0) {
      EXPECT_NEAR((Kp - Kx).norm(), 0.0, 1e-12);  // stretched: unchanged
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
