#include "engine/solvers/fem_corotational.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace palplab::engine {

void polar_decomposition(const Eigen::Matrix3d& F, Eigen::Matrix3d& R, Eigen::Matrix3d& S) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU(), V = svd.matrixV();
  Eigen::Vector3d sigma = svd.singularValues();  // descending
  if (U.determinant() < 0) {
    U.col(2) *= -1;
    sigma[2] *= -1;
  }
  if (V.determinant() < 0) {
    V.col(2) *= -1;
    sigma[2] *= -1;
  }
  R = U * V.transpose();
  S = V * sigma.asDiagonal() * V.transpose();
}

namespace {

Eigen::Vector3d axial(const Eigen::Matrix3d& M) {  // of the skew matrix M
  return {M(2, 1), M(0, 2), M(1, 0)};
}

// (tr S I - S)^-1 through the eigen-decomposition of S, eigenvalue sums clamped away from 0
// (1e-6 |S|): the map from axial(R^T dF - dF^T R) to the axial vector of W = R^T dR.
Eigen::Matrix3d rotation_gradient_inverse(const Eigen::Matrix3d& S) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(S);
  const Eigen::Vector3d l = es.eigenvalues();
  const double scale = std::max(l.cwiseAbs().maxCoeff(), 1e-300);
  Eigen::Vector3d inv;
  for (int k = 0; k < 3; ++k) {
    double m = l.sum() - l[k];
    if (std::abs(m) < 1e-6 * scale) m = m < 0 ? -1e-6 * scale : 1e-6 * scale;
    inv[k] = 1.0 / m;
  }
  return es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose();
}

Eigen::Matrix3d skew(const Eigen::Vector3d& w) {
  Eigen::Matrix3d W;
  W << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return W;
}

Vector12d rotate_blocks(const Eigen::Matrix3d& R, const Vector12d& v) {
  Vector12d out;
  for (int r = 0; r < 4; ++r) out.segment<3>(3 * r) = R * v.segment<3>(3 * r);
  return out;
}

}  // namespace

void corotational_element(const Matrix43d& grad, const Matrix12d& Ke, const Vector12d& X0,
                          const Vector12d& x, CorotJacobian jac, Vector12d& f_e, Matrix12d* K_e_t) {
  const Eigen::Matrix3d F = deformation_gradient(grad, x);
  Eigen::Matrix3d R, S;
  polar_decomposition(F, R, S);
  Vector12d y = rotate_blocks(R.transpose(), x);
  const Vector12d g = Ke * (y - X0);  // force of the unrotated displacement, element frame
  f_e = -rotate_blocks(R, g);
  if (!K_e_t) return;
  // Warped part R K_e R^T, block by block (R acts per node).
  Matrix12d Kt;
  for (int q = 0; q < 4; ++q)
    for (int r = 0; r < 4; ++r)
      Kt.block<3, 3>(3 * r, 3 * q).noalias() = R * Ke.block<3, 3>(3 * r, 3 * q) * R.transpose();
  if (jac == CorotJacobian::exact) {
    const Eigen::Matrix3d G = rotation_gradient_inverse(S);
    // Column k (dx = e_k): R (W_k g' - K_e W_k y) with W_k = [w_k]x.
    // w_k = G axial(A - A^T), A = R^T dF = (R^T e_c) grad N_node^T.
    Matrix12d H, Q;
    for (int k = 0; k < 12; ++k) {
      const int node = k / 3, c = k % 3;
      const Eigen::Matrix3d A = R.transpose().col(c) * grad.row(node);
      const Eigen::Vector3d w = G * axial(A - A.transpose());
      for (int r = 0; r < 4; ++r) {
        H.block<3, 1>(3 * r, k) = w.cross(g.segment<3>(3 * r));
        Q.block<3, 1>(3 * r, k) = w.cross(y.segment<3>(3 * r));
      }
    }
    H.noalias() -= Ke * Q;
    for (int r = 0; r < 4; ++r) Kt.middleRows<3>(3 * r).noalias() += R * H.middleRows<3>(3 * r);
    Kt = 0.5 * (Kt + Kt.transpose()).eval();
  }
  *K_e_t = Kt;
}

namespace {
Vector12d element_vector(const mesh::Tets& T, long t, const Eigen::VectorXd& x) {
  Vector12d v;
  for (int r = 0; r < 4; ++r) v.segment<3>(3 * r) = x.segment<3>(3 * T(t, r));
  return v;
}

// One tet of sys in the given material.
void element_of(const FemSystem& sys, long t, const Eigen::VectorXd& X0, const Eigen::VectorXd& x,
                CorotJacobian jac, CorotMaterial material, Vector12d& fe, Matrix12d* Kt) {
  if (material != CorotMaterial::corotated_linear) {
    double mu = 0, lambda = 0;
    lame(sys.material.youngs_modulus[t], sys.material.poisson_ratio[t], mu, lambda);
    const auto element =
        material == CorotMaterial::fixed_corotated ? fixed_corotated_element : neo_hookean_element;
    element(sys.shape[t].grad, std::abs(sys.shape[t].volume), mu, lambda,
            element_vector(sys.T, t, x), fe, Kt);
    return;
  }
  corotational_element(sys.shape[t].grad, sys.Ke[t], element_vector(sys.T, t, X0),
                       element_vector(sys.T, t, x), jac, fe, Kt);
}
}  // namespace

const char* to_string(CorotMaterial m) {
  switch (m) {
    case CorotMaterial::fixed_corotated:
      return "fixed-corotated";
    case CorotMaterial::neo_hookean:
      return "neo-hookean";
    case CorotMaterial::corotated_linear:
      break;
  }
  return "corotated-linear";
}

CorotMaterial parse_corot_material(const std::string& name) {
  for (CorotMaterial m : {CorotMaterial::corotated_linear, CorotMaterial::fixed_corotated,
                          CorotMaterial::neo_hookean})
    if (name == to_string(m)) return m;
  throw std::invalid_argument("expected corotated-linear, fixed-corotated or neo-hookean, got \"" +
                              name + "\"");
}

void corotational_forces(const FemSystem& sys, const Eigen::VectorXd& x, Eigen::VectorXd& f,
                         std::vector<Eigen::Matrix3d>* R_out, CorotMaterial material) {
  const Eigen::VectorXd X0 = flatten(sys.X0);
  f.setZero(x.size());
  if (R_out) R_out->resize(sys.T.rows());
  for (long t = 0; t < sys.T.rows(); ++t) {
    Vector12d fe;
    element_of(sys, t, X0, x, CorotJacobian::warped, material, fe, nullptr);
    for (int r = 0; r < 4; ++r) f.segment<3>(3 * sys.T(t, r)) += fe.segment<3>(3 * r);
    if (R_out) {
      Eigen::Matrix3d S;
      polar_decomposition(deformation_gradient(sys.shape[t].grad, element_vector(sys.T, t, x)),
                          (*R_out)[t], S);
    }
  }
}

void corotational_stiffness(const FemSystem& sys, const Eigen::VectorXd& x, CorotJacobian jac,
                            std::vector<Matrix12d>& Ke_t, SparseMatrixd& K_t, Eigen::VectorXd* f,
                            CorotMaterial material) {
  if (material != CorotMaterial::corotated_linear && jac != CorotJacobian::exact)
    throw std::invalid_argument(std::string("corotational_stiffness: ") + to_string(material) +
                                " has the exact tangent only");
  const Eigen::VectorXd X0 = flatten(sys.X0);
  Ke_t.resize(sys.T.rows());
  if (f) f->setZero(x.size());
  for (long t = 0; t < sys.T.rows(); ++t) {
    Vector12d fe;
    element_of(sys, t, X0, x, jac, material, fe, &Ke_t[t]);
    if (f)
      for (int r = 0; r < 4; ++r) f->segment<3>(3 * sys.T(t, r)) += fe.segment<3>(3 * r);
  }
  assemble(sys.pattern, Ke_t, K_t);
}

Eigen::Matrix3d corotational_stress(const Eigen::Matrix3d& F, double mu, double lambda) {
  Eigen::Matrix3d R, S;
  polar_decomposition(F, R, S);
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  return R * (2 * mu * (S - I) + lambda * (S - I).trace() * I);
}

Matrix9d corotational_material_tangent(const Eigen::Matrix3d& F, double mu, double lambda) {
  Eigen::Matrix3d R, S;
  polar_decomposition(F, R, S);
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d tau = 2 * mu * (S - I) + lambda * (S - I).trace() * I;  // P = R tau
  const Eigen::Matrix3d G = rotation_gradient_inverse(S);
  Matrix9d C;
  for (int col = 0; col < 9; ++col) {
    Eigen::Matrix3d dF = Eigen::Matrix3d::Zero();
    dF(col % 3, col / 3) = 1;
    // F = R S: R^T dF = W S + dS with W = R^T dR skew, dS symmetric.
    const Eigen::Matrix3d A = R.transpose() * dF;
    const Eigen::Matrix3d W = skew(G * axial(A - A.transpose()));
    const Eigen::Matrix3d dS = A - W * S;
    const Eigen::Matrix3d dtau = 2 * mu * dS + lambda * dS.trace() * I;
    const Eigen::Matrix3d dP = R * (W * tau + dtau);
    C.col(col) = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(dP.data());
  }
  return C;
}

namespace {
Eigen::Matrix3d cofactor(const Eigen::Matrix3d& F) {
  Eigen::Matrix3d c;
  c.col(0) = F.col(1).cross(F.col(2));
  c.col(1) = F.col(2).cross(F.col(0));
  c.col(2) = F.col(0).cross(F.col(1));
  return c;
}
}  // namespace

Eigen::Matrix3d fixed_corotated_stress(const Eigen::Matrix3d& F, double mu, double lambda) {
  Eigen::Matrix3d R, S;
  polar_decomposition(F, R, S);
  return 2 * mu * (F - R) + lambda * (F.determinant() - 1) * cofactor(F);
}

Matrix9d fixed_corotated_tangent(const Eigen::Matrix3d& F, double mu, double lambda) {
  Eigen::Matrix3d R, S;
  polar_decomposition(F, R, S);
  const Eigen::Matrix3d G = rotation_gradient_inverse(S);
  const Eigen::Matrix3d cof = cofactor(F);
  const double J = F.determinant();
  const Eigen::Map<const Eigen::Matrix<double, 9, 1>> vc(cof.data());
  Matrix9d C;
  for (int col = 0; col < 9; ++col) {
    Eigen::Matrix3d dF = Eigen::Matrix3d::Zero();
    dF(col % 3, col / 3) = 1;
    const Eigen::Matrix3d A = R.transpose() * dF;
    const Eigen::Matrix3d dR = R * skew(G * axial(A - A.transpose()));
    Eigen::Matrix3d dcof;  // d(cof F): the columns' cross products differentiated
    dcof.col(0) = dF.col(1).cross(F.col(2)) + F.col(1).cross(dF.col(2));
    dcof.col(1) = dF.col(2).cross(F.col(0)) + F.col(2).cross(dF.col(0));
    dcof.col(2) = dF.col(0).cross(F.col(1)) + F.col(0).cross(dF.col(1));
    const Eigen::Matrix3d dP =
        2 * mu * (dF - dR) + lambda * vc[col] * cof + lambda * (J - 1) * dcof;
    C.col(col) = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(dP.data());
  }
  return C;
}

namespace {
// One tet of a hyperelastic material given by its stress P(F) and tangent C(F): the force
// f_r = -V P grad N_r and the tangent V G^T C G.
void hyperelastic_element(Eigen::Matrix3d (*stress)(const Eigen::Matrix3d&, double, double),
                          Matrix9d (*tangent)(const Eigen::Matrix3d&, double, double),
                          const Matrix43d& grad, double volume, double mu, double lambda,
                          const Vector12d& x, Vector12d& f_e, Matrix12d* K_e_t) {
  const Eigen::Matrix3d F = deformation_gradient(grad, x);
  const Eigen::Matrix3d P = stress(F, mu, lambda);
  for (int r = 0; r < 4; ++r) f_e.segment<3>(3 * r) = -volume * P * grad.row(r).transpose();
  if (!K_e_t) return;
  // G = d vec(F) / d x_e: vec(F)[i + 3 j] = sum_r x_r[i] grad(r, j).
  Eigen::Matrix<double, 9, 12> Gm = Eigen::Matrix<double, 9, 12>::Zero();
  for (int r = 0; r < 4; ++r)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) Gm(i + 3 * j, 3 * r + i) = grad(r, j);
  Matrix12d K = volume * Gm.transpose() * tangent(F, mu, lambda) * Gm;
  *K_e_t = 0.5 * (K + K.transpose());
}
}  // namespace

void fixed_corotated_element(const Matrix43d& grad, double volume, double mu, double lambda,
                             const Vector12d& x, Vector12d& f_e, Matrix12d* K_e_t) {
  hyperelastic_element(fixed_corotated_stress, fixed_corotated_tangent, grad, volume, mu, lambda, x,
                       f_e, K_e_t);
}

Eigen::Matrix3d neo_hookean_stress(const Eigen::Matrix3d& F, double mu, double lambda) {
  const double J = F.determinant();
  if (!(J > 0)) return Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN());
  const Eigen::Matrix3d FinvT = F.inverse().transpose();
  return mu * (F - FinvT) + lambda * std::log(J) * FinvT;
}

Matrix9d neo_hookean_tangent(const Eigen::Matrix3d& F, double mu, double lambda) {
  const double J = F.determinant();
  if (!(J > 0)) return Matrix9d::Constant(std::numeric_limits<double>::quiet_NaN());
  const Eigen::Matrix3d Finv = F.inverse();
  const double a = mu - lambda * std::log(J);
  Matrix9d C;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 3; ++l)
          C(i + 3 * j, k + 3 * l) = (i == k && j == l ? mu : 0.0) + a * Finv(j, k) * Finv(l, i) +
                                    lambda * Finv(j, i) * Finv(l, k);
  return C;
}

void neo_hookean_element(const Matrix43d& grad, double volume, double mu, double lambda,
                         const Vector12d& x, Vector12d& f_e, Matrix12d* K_e_t) {
  hyperelastic_element(neo_hookean_stress, neo_hookean_tangent, grad, volume, mu, lambda, x, f_e,
                       K_e_t);
}

Matrix9d material_tangent(CorotMaterial material, const Eigen::Matrix3d& F, double mu,
                          double lambda) {
  switch (material) {
    case CorotMaterial::fixed_corotated:
      return fixed_corotated_tangent(F, mu, lambda);
    case CorotMaterial::neo_hookean:
      return neo_hookean_tangent(F, mu, lambda);
    case CorotMaterial::corotated_linear:
      break;
  }
  return corotational_material_tangent(F, mu, lambda);
}

namespace {
// The acoustic tensor Q(n) of C and, for its smallest eigenpair (value, a), the gradient of that
// eigenvalue in n: d/dn_j (a^T Q(n) a) = 2 sum_ikl a_i C(i + 3 j, k + 3 l) a_k n_l.
Eigen::Matrix3d acoustic(const Matrix9d& C, const Eigen::Vector3d& n) {
  Eigen::Matrix3d Q = Eigen::Matrix3d::Zero();
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < 3; ++j)
        for (int l = 0; l < 3; ++l) Q(i, k) += C(i + 3 * j, k + 3 * l) * n[j] * n[l];
  return 0.5 * (Q + Q.transpose());
}
double acoustic_smallest(const Matrix9d& C, const Eigen::Vector3d& n, Eigen::Vector3d* a) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(acoustic(C, n));
  if (a) *a = es.eigenvectors().col(0);
  return es.eigenvalues()[0];
}
}  // namespace

double acoustic_tensor_min(const Matrix9d& C, Eigen::Vector3d* n_min) {
  // Q(n) = Q(-n): a Fibonacci lattice on the upper hemisphere.
  constexpr int kSamples = 600;
  const double golden = std::numbers::pi * (3 - std::sqrt(5.0));
  double best = std::numeric_limits<double>::infinity();
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  for (int k = 0; k < kSamples; ++k) {
    const double z = 1 - (k + 0.5) / kSamples, r = std::sqrt(1 - z * z), phi = golden * k;
    const Eigen::Vector3d d(r * std::cos(phi), r * std::sin(phi), z);
    const double v = acoustic_smallest(C, d, nullptr);
    if (v < best) {
      best = v;
      n = d;
    }
  }
  // Projected gradient descent on the sphere with a halving step (the sampling spacing is
  // ~0.07 rad; the minimum is smooth near a simple eigenvalue).
  double step = 0.05;
  for (int it = 0; it < 60 && step > 1e-9; ++it) {
    Eigen::Vector3d a;
    acoustic_smallest(C, n, &a);
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k)
          for (int l = 0; l < 3; ++l) g[j] += 2 * a[i] * C(i + 3 * j, k + 3 * l) * a[k] * n[l];
    g -= g.dot(n) * n;  // tangential part
    if (!(g.norm() > 0)) break;
    const Eigen::Vector3d trial = (n - step * g.normalized()).normalized();
    const double v = acoustic_smallest(C, trial, nullptr);
    if (v < best) {
      best = v;
      n = trial;
      step *= 1.5;
    } else {
      step *= 0.5;
    }
  }
  if (n_min) *n_min = n;
  return best;
}

}  // namespace palplab::engine
