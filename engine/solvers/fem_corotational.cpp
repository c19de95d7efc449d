#include "engine/solvers/fem_corotational.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

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
    // (tr S I - S)^-1 through the eigen-decomposition of S, eigenvalue sums clamped.
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
    const Eigen::Matrix3d G = es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose();
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
}  // namespace

void corotational_forces(const FemSystem& sys, const Eigen::VectorXd& x, Eigen::VectorXd& f,
                         std::vector<Eigen::Matrix3d>* R_out) {
  const Eigen::VectorXd X0 = flatten(sys.X0);
  f.setZero(x.size());
  if (R_out) R_out->resize(sys.T.rows());
  for (long t = 0; t < sys.T.rows(); ++t) {
    Vector12d fe;
    corotational_element(sys.shape[t].grad, sys.Ke[t], element_vector(sys.T, t, X0),
                         element_vector(sys.T, t, x), CorotJacobian::warped, fe, nullptr);
    for (int r = 0; r < 4; ++r) f.segment<3>(3 * sys.T(t, r)) += fe.segment<3>(3 * r);
    if (R_out) {
      Eigen::Matrix3d S;
      polar_decomposition(deformation_gradient(sys.shape[t].grad, element_vector(sys.T, t, x)),
                          (*R_out)[t], S);
    }
  }
}

void corotational_stiffness(const FemSystem& sys, const Eigen::VectorXd& x, CorotJacobian jac,
                            std::vector<Matrix12d>& Ke_t, SparseMatrixd& K_t, Eigen::VectorXd* f) {
  const Eigen::VectorXd X0 = flatten(sys.X0);
  Ke_t.resize(sys.T.rows());
  if (f) f->setZero(x.size());
  for (long t = 0; t < sys.T.rows(); ++t) {
    Vector12d fe;
    corotational_element(sys.shape[t].grad, sys.Ke[t], element_vector(sys.T, t, X0),
                         element_vector(sys.T, t, x), jac, fe, &Ke_t[t]);
    if (f)
      for (int r = 0; r < 4; ++r) f->segment<3>(3 * sys.T(t, r)) += fe.segment<3>(3 * r);
  }
  assemble(sys.pattern, Ke_t, K_t);
}

}  // namespace palplab::engine
