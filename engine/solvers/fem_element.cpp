#include "engine/solvers/fem_element.hpp"

#include <Eigen/LU>
#include <cmath>
#include <stdexcept>

namespace palplab::engine {

TetShape tet_shape(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                   const Eigen::Vector3d& d) {
  Eigen::Matrix3d Dm;
  Dm.col(0) = b - a;
  Dm.col(1) = c - a;
  Dm.col(2) = d - a;
  TetShape s;
  s.volume = Dm.determinant() / 6.0;
  double longest = std::max({(b - a).norm(), (c - a).norm(), (d - a).norm(), (c - b).norm(),
                             (d - b).norm(), (d - c).norm()});
  if (!(std::abs(s.volume) > 1e-14 * longest * longest * longest))
    throw std::invalid_argument("tet_shape: degenerate tetrahedron (zero volume)");
  const Eigen::Matrix3d inv = Dm.inverse();
  s.grad.row(1) = inv.row(0);
  s.grad.row(2) = inv.row(1);
  s.grad.row(3) = inv.row(2);
  s.grad.row(0) = -(inv.row(0) + inv.row(1) + inv.row(2));
  return s;
}

Matrix6x12d strain_displacement(const Matrix43d& grad) {
  Matrix6x12d B = Matrix6x12d::Zero();
  for (int r = 0; r < 4; ++r) {
    const double gx = grad(r, 0), gy = grad(r, 1), gz = grad(r, 2);
    const int c = 3 * r;
    B(0, c) = gx;
    B(1, c + 1) = gy;
    B(2, c + 2) = gz;
    B(3, c + 1) = gz;  // g_yz = du_y/dz + du_z/dy
    B(3, c + 2) = gy;
    B(4, c) = gz;  // g_xz
    B(4, c + 2) = gx;
    B(5, c) = gy;  // g_xy
    B(5, c + 1) = gx;
  }
  return B;
}

Matrix6d isotropic_elasticity(double E, double nu) {
  if (!(E > 0) || !(nu > -1.0 && nu < 0.5))
    throw std::invalid_argument("isotropic_elasticity: need E > 0 and -1 < nu < 0.5");
  const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu));
  const double mu = E / (2 * (1 + nu));
  Matrix6d D = Matrix6d::Zero();
  D.topLeftCorner<3, 3>().setConstant(lambda);
  for (int i = 0; i < 3; ++i) {
    D(i, i) = lambda + 2 * mu;
    D(3 + i, 3 + i) = mu;
  }
  return D;
}

Matrix12d element_stiffness(const TetShape& s, double E, double nu) {
  const Matrix6x12d B = strain_displacement(s.grad);
  const Matrix6d D = isotropic_elasticity(E, nu);
  Matrix12d K = std::abs(s.volume) * (B.transpose() * D * B);
  return 0.5 * (K + K.transpose());  // exactly symmetric (the solver reads one triangle)
}

Matrix12d element_mass_consistent(const TetShape& s, double density) {
  const double m = density * std::abs(s.volume) / 20.0;
  Matrix12d M = Matrix12d::Zero();
  for (int r = 0; r < 4; ++r)
    for (int q = 0; q < 4; ++q)
      for (int k = 0; k < 3; ++k) M(3 * r + k, 3 * q + k) = (r == q ? 2.0 : 1.0) * m;
  return M;
}

double element_mass_lumped(const TetShape& s, double density) {
  return density * std::abs(s.volume) / 4.0;
}

Eigen::Matrix3d deformation_gradient(const Matrix43d& grad, const Vector12d& x) {
  Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
  for (int r = 0; r < 4; ++r) F += x.segment<3>(3 * r) * grad.row(r);
  return F;
}

}  // namespace palplab::engine
