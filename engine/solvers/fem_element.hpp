#pragma once
// Linear tetrahedral finite element: shape-function gradients, strain-displacement
// matrix B, isotropic elasticity D(E, nu), element stiffness K_e = V B^T D B and element masses.
//
// Node ordering of a tet is (a, b, c, d) as in tet_mesh.hpp; element vectors have 12 entries,
// node-major: (x_a, y_a, z_a, x_b, ...). Voigt order of strain and stress:
//   (e_xx, e_yy, e_zz, g_yz, g_xz, g_xy) with engineering shear g = 2 e.
// Units: positions m, E Pa, density kg/m^3; K_e N/m, masses kg.
#include <Eigen/Core>

namespace palplab::engine {

using Matrix12d = Eigen::Matrix<double, 12, 12>;
using Vector12d = Eigen::Matrix<double, 12, 1>;
using Matrix43d = Eigen::Matrix<double, 4, 3>;
using Matrix6x12d = Eigen::Matrix<double, 6, 12>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Linear shape functions N_r(x) of the tet (a, b, c, d): grad row r = grad N_r (1/m), constant
// over the element; volume = signed volume (b-a).((c-a)x(d-a))/6 (m^3). With x = a + Dm xi,
// Dm = [b-a, c-a, d-a], grad N_{1..3} are the rows of Dm^-1 and grad N_0 = -(sum of the others).
// Throws std::invalid_argument for a degenerate tet (|volume| <= 1e-14 * longest edge^3).
struct TetShape {
  Matrix43d grad;
  double volume = 0;
};
TetShape tet_shape(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                   const Eigen::Vector3d& d);

// 6 by 12 strain-displacement matrix: strain = B u_e.
Matrix6x12d strain_displacement(const Matrix43d& grad);

// 6 by 6 isotropic elasticity (Voigt, engineering shear): stress = D strain.
// Requires E > 0 and -1 < nu < 0.5 (throws std::invalid_argument otherwise).
Matrix6d isotropic_elasticity(double youngs_modulus, double poisson_ratio);

// K_e = |V| B^T D B (N/m), symmetric, positive semi-definite with the six rigid modes as kernel.
Matrix12d element_stiffness(const TetShape& s, double youngs_modulus, double poisson_ratio);

// Consistent mass rho |V| / 20 (1 + delta_rs) I3 per node pair (kg); its total is rho |V|.
Matrix12d element_mass_consistent(const TetShape& s, double density);
// Lumped (row-sum) mass of each node: rho |V| / 4 (kg).
double element_mass_lumped(const TetShape& s, double density);

// Deformation gradient F = sum_r x_r grad N_r^T of the element at current positions x (12).
Eigen::Matrix3d deformation_gradient(const Matrix43d& grad, const Vector12d& x);

}  // namespace palplab::engine
