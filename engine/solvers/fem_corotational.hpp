#pragma once
// Co-rotational linear FEM (stiffness warping done with the rotation-gradient terms).
//
// Per tet, F = sum_r x_r grad N_r^T is split by the polar decomposition F = R S (R a proper
// rotation, S symmetric). The element energy is the linear one of the unrotated displacement,
//   E_e(x) = 1/2 u'^T K_e u',   u'_r = R^T x_r - X0_r,
// and its exact gradient is g_e = R K_e u' (block-wise R): for an isotropic D the terms from
// dR/dx cancel in the gradient because the stress of u' commutes with S (McAdams et al. 2011).
// The internal force is f_e = -g_e; it is invariant under a rigid motion of x and equals the
// linear -K_e (x - X0) to first order in the strain.
//
// The tangent (Hessian) is NOT only the warped stiffness R K_e R^T: differentiating g_e gives
//   dg_e = R K_e R^T dx + R (W g' - K_e W y),   y_r = R^T x_r, g' = K_e u', W = R^T dR (skew),
// with the axial vector of W from the polar derivative
//   w = (tr(S) I - S)^-1 axial(R^T dF - dF^T R).
// CorotJacobian::exact includes these rotation-gradient terms (the consistent Newton tangent;
// finite-difference tested in tests/fem); CorotJacobian::warped drops them (Mueller & Gross
// 2004 stiffness warping: symmetric positive semi-definite, off by O(strain) — the terms vanish
// at rest). Where tr(S) I - S is (nearly) singular — two singular values summing to ~0, only in
// a strongly inverted element — its eigenvalues are clamped away from 0 (1e-6 of |S|), so the
// tangent stays bounded; the force is unaffected.
//
// Inversion: R comes from the SVD F = U Sigma V^T with the sign of the smallest singular value
// flipped when det F < 0 (Irving et al. 2004), so R is always a rotation and an inverted
// element is pushed back out instead of being reflected.
#include <Eigen/Core>
#include <vector>

#include "engine/solvers/fem_assembly.hpp"

namespace palplab::engine {

// F = R S with det R = +1, S symmetric (one negative eigenvalue iff det F < 0).
void polar_decomposition(const Eigen::Matrix3d& F, Eigen::Matrix3d& R, Eigen::Matrix3d& S);

enum class CorotJacobian { exact, warped };

// Internal elastic forces f (3#V, N) at current positions x (3#V, m); R_out (optional) gets the
// per-tet rotation.
void corotational_forces(const FemSystem& sys, const Eigen::VectorXd& x, Eigen::VectorXd& f,
                         std::vector<Eigen::Matrix3d>* R_out = nullptr);

// Tangent stiffness K_t = -df/dx at x, assembled on sys.pattern into K_t (N/m, symmetrised);
// Ke_t is the per-tet workspace (#T). With f != nullptr the internal forces of the same pass
// (identical to corotational_forces) are written too, so a step does one SVD per tet.
void corotational_stiffness(const FemSystem& sys, const Eigen::VectorXd& x, CorotJacobian jac,
                            std::vector<Matrix12d>& Ke_t, SparseMatrixd& K_t,
                            Eigen::VectorXd* f = nullptr);

// One tet: force f_e (12) and, when K_e_t != nullptr, its tangent -df_e/dx_e (12 by 12).
void corotational_element(const Matrix43d& grad, const Matrix12d& Ke, const Vector12d& X0,
                          const Vector12d& x, CorotJacobian jac, Vector12d& f_e, Matrix12d* K_e_t);

}  // namespace palplab::engine
