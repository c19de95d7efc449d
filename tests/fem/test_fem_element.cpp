// Linear tet element: shape gradients, D(E, nu), K_e kernel and symmetry, masses, and the
// tissue-table materials (rigid tissue fixed, unknown attribute rejected).
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include "common/input_error.hpp"
#include "engine/mesh/materials.hpp"
#include "engine/models/fem_block_mesh.hpp"
#include "engine/solvers/fem_assembly.hpp"
#include "engine/solvers/fem_element.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {
const Eigen::Vector3d a(0.01, 0.0, 0.002), b(0.03, 0.001, 0.0), c(0.012, 0.025, 0.001),
    d(0.015, 0.008, 0.02);
}

TEST(FemElement, ShapeGradientsReproduceLinearFields) {
  const TetShape s = tet_shape(a, b, c, d);
  EXPECT_NEAR(s.volume, mesh::signed_volume(a, b, c, d), 1e-20);
  // sum grad N_r = 0 and sum x_r grad N_r^T = I (linear completeness).
  Vector12d x;
  x << a, b, c, d;
  EXPECT_LT(s.grad.colwise().sum().cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_LT((deformation_gradient(s.grad, x) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(),
            1e-13);
  EXPECT_THROW(tet_shape(a, b, c, a + 0.5 * (b - a)), std::invalid_argument);
}

TEST(FemElement, IsotropicElasticityMatchesLame) {
  const double E = 2e4, nu = 0.3;
  const Matrix6d D = isotropic_elasticity(E, nu);
  const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
  EXPECT_NEAR(D(0, 0), lambda + 2 * mu, 1e-9);
  EXPECT_NEAR(D(0, 1), lambda, 1e-9);
  EXPECT_NEAR(D(3, 3), mu, 1e-9);
  EXPECT_EQ(D(0, 3), 0.0);
  // Uniaxial stress: compliance D^-1 gives strain_xx = 1/E, strain_yy = -nu/E.
  const Matrix6d C = D.inverse();
  EXPECT_NEAR(C(0, 0) * E, 1.0, 1e-12);
  EXPECT_NEAR(C(1, 0) * E, -nu, 1e-12);
  EXPECT_THROW(isotropic_elasticity(1e4, 0.5), std::invalid_argument);
  EXPECT_THROW(isotropic_elasticity(0, 0.3), std::invalid_argument);
}

TEST(FemElement, StiffnessHasSixRigidModesAndMassesSumToRhoV) {
  const TetShape s = tet_shape(a, b, c, d);
  const Matrix12d K = element_stiffness(s, 1e4, 0.45);
  EXPECT_EQ((K - K.transpose()).cwiseAbs().maxCoeff(), 0.0);
  Eigen::SelfAdjointEigenSolver<Matrix12d> es(K);
  const auto l = es.eigenvalues();
  for (int i = 0; i < 6; ++i) EXPECT_LT(std::abs(l[i]), 1e-10 * l[11]);
  EXPECT_GT(l[6], 1e-6 * l[11]);
  // Infinitesimal rotation about an arbitrary axis gives no force.
  Vector12d x;
  x << a, b, c, d;
  Vector12d u;
  const Eigen::Vector3d w(0.3, -1.0, 0.5);
  for (int r = 0; r < 4; ++r) u.segment<3>(3 * r) = w.cross(x.segment<3>(3 * r));
  EXPECT_LT((K * u).cwiseAbs().maxCoeff(), 1e-12 * K.cwiseAbs().maxCoeff() * u.norm());
  const double rho = 1060;
  EXPECT_NEAR(element_mass_consistent(s, rho).sum() / 3, rho * s.volume, 1e-15);
  EXPECT_NEAR(4 * element_mass_lumped(s, rho), rho * s.volume, 1e-15);
}

TEST(FemAssembly, MaterialsFromTissueTableAndRigidNodes) {
  mesh::TetMesh m = fem_block_mesh(2, 1, 1, Eigen::Vector3d(0.02, 0.01, 0.01), 101);
  for (long t = 0; t < 6; ++t) m.attribute[t] = 200;  // first hex is bone
  const TetMaterials mat = tet_materials(m, mesh::default_materials());
  EXPECT_EQ(mat.youngs_modulus[6], 10000.0);  // soft tissue, SI (Pa)
  EXPECT_EQ(mat.poisson_ratio[6], 0.45);
  EXPECT_EQ(mat.density[6], 1000.0);
  EXPECT_TRUE(mat.rigid[0]);
  const auto fixed = rigid_nodes(m, mat);
  for (long i = 0; i < m.V.rows(); ++i) EXPECT_EQ(fixed[i], m.V(i, 0) <= 0.01 + 1e-12) << i;
  m.attribute[3] = 1000;  // not in the table
  EXPECT_THROW(tet_materials(m, mesh::default_materials()), InputError);
}

TEST(FemAssembly, PatternIsReusedAndMassIsConsistent) {
  const mesh::TetMesh m = fem_block_mesh(2, 2, 2, Eigen::Vector3d(0.02, 0.02, 0.02), 101, 0.1);
  const FemSystem s = fem_precompute(m.V, m.T, uniform_materials(m.T.rows(), 1e4, 0.45, 1000));
  // Re-assembling twice the element matrices on the same pattern doubles the values.
  std::vector<Matrix12d> twice = s.Ke;
  for (auto& k : twice) k *= 2;
  SparseMatrixd K2 = s.K;
  assemble(s.pattern, twice, K2);
  EXPECT_EQ(K2.nonZeros(), s.K.nonZeros());
  EXPECT_LT((K2 - 2 * s.K).norm(), 1e-12 * s.K.norm());
  // Total mass: consistent (any row sum per axis) and lumped both equal rho * volume.
  const double mass = 1000 * 0.02 * 0.02 * 0.02;
  EXPECT_NEAR(s.m_lumped.sum() / 3, mass, 1e-15);
  EXPECT_NEAR(s.M.sum() / 3, mass, 1e-15);
  // Inverted tet -> InputError naming it.
  mesh::Tets T = m.T;
  std::swap(T(4, 0), T(4, 1));
  EXPECT_THROW(fem_precompute(m.V, T, uniform_materials(T.rows(), 1e4, 0.45, 1000)), InputError);
}
