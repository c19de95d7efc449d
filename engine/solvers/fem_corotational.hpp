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
#include <string>
#include <vector>

#include "engine/solvers/fem_assembly.hpp"

namespace palplab::engine {

// F = R S with det R = +1, S symmetric (one negative eigenvalue iff det F < 0).
void polar_decomposition(const Eigen::Matrix3d& F, Eigen::Matrix3d& R, Eigen::Matrix3d& S);

enum class CorotJacobian { exact, warped };

// The material of the co-rotational element (both equal linear elasticity to first order in the
// strain, so the static reference and the small-load curve do not depend on the choice):
//   corotated_linear  psi = mu |S - I|^2 + lambda/2 tr(S - I)^2: the linear element rotated
//                     (1/2 u'^T K_e u', the haptic models' D_corot). Loses strong ellipticity
//                     under moderate compression (acoustic_tensor_min below): det F = 0.82
//                     hydrostatic at nu = 0.45.
//   fixed_corotated   psi = mu |S - I|^2 + lambda/2 (det F - 1)^2 (Stomakhin et al. 2012): the
//                     volume term in J, whose pressure does no initial-stress work on a rank-one
//                     perturbation (cof F is a null Lagrangian), so it stays strongly elliptic
//                     while the singular values pairwise sum above 1 (hydrostatic: s > 1/2).
//                     No barrier against inversion: under a large press tets collapse (det F
//                     0.05 on the test block's level 2 at 4 N).
//   neo_hookean       psi = mu/2 (tr F^T F - 3) - mu ln J + lambda/2 (ln J)^2, J = det F (the
//                     compressible neo-Hookean solid, as FEBio's "neo-Hookean"; Bonet & Wood
//                     2008, eq. 6.28): polyconvex, so strongly elliptic for every J > 0, and its
//                     energy grows without bound as J -> 0, a barrier against inversion. Not
//                     defined for J <= 0: the stress there is NaN, which the curve's line search
//                     rejects (a step that inverts a tet is shortened).
// (Not all co-rotational: the name is that of the curve's geometrically nonlinear element.)
enum class CorotMaterial { corotated_linear, fixed_corotated, neo_hookean };
const char* to_string(CorotMaterial m);
// "corotated-linear", "fixed-corotated" or "neo-hookean"; throws std::invalid_argument otherwise.
CorotMaterial parse_corot_material(const std::string& name);

// Internal elastic forces f (3#V, N) at current positions x (3#V, m); R_out (optional) gets the
// per-tet rotation.
void corotational_forces(const FemSystem& sys, const Eigen::VectorXd& x, Eigen::VectorXd& f,
                         std::vector<Eigen::Matrix3d>* R_out = nullptr,
                         CorotMaterial material = CorotMaterial::corotated_linear);

// Tangent stiffness K_t = -df/dx at x, assembled on sys.pattern into K_t (N/m, symmetrised);
// Ke_t is the per-tet workspace (#T). With f != nullptr the internal forces of the same pass
// (identical to corotational_forces) are written too, so a step does one SVD per tet.
// (fixed_corotated: jac must be exact.)
void corotational_stiffness(const FemSystem& sys, const Eigen::VectorXd& x, CorotJacobian jac,
                            std::vector<Matrix12d>& Ke_t, SparseMatrixd& K_t,
                            Eigen::VectorXd* f = nullptr,
                            CorotMaterial material = CorotMaterial::corotated_linear);

// One tet: force f_e (12) and, when K_e_t != nullptr, its tangent -df_e/dx_e (12 by 12).
void corotational_element(const Matrix43d& grad, const Matrix12d& Ke, const Vector12d& X0,
                          const Vector12d& x, CorotJacobian jac, Vector12d& f_e, Matrix12d* K_e_t);

// The continuum material behind the element: the co-rotated linear energy density (Pa)
//   psi(F) = mu |S - I|^2 + lambda / 2 tr(S - I)^2,   F = R S,
// whose element energy V psi(F) is the 1/2 u'^T K_e u' above (K_e = V B^T D B with the Lame
// constants of D). Its first Piola-Kirchhoff stress P = d psi / dF = R (2 mu (S - I) +
// lambda tr(S - I) I) gives the element force f_r = -V P grad N_r.
Eigen::Matrix3d corotational_stress(const Eigen::Matrix3d& F, double mu, double lambda);
// The material tangent C = dP/dF (Pa) as a 9 by 9 matrix on column-major vec(F)
// (vec(F)[i + 3 j] = F(i, j)), with the rotation gradient of the exact element tangent (the same
// clamping): the exact element tangent is V G^T C G, G = d vec(F) / d x_e.
using Matrix9d = Eigen::Matrix<double, 9, 9>;
Matrix9d corotational_material_tangent(const Eigen::Matrix3d& F, double mu, double lambda);

// The fixed co-rotated material: P = 2 mu (F - R) + lambda (J - 1) cof F, its tangent dP/dF
// (same layout), and one tet's force f_r = -V P grad N_r and tangent V G^T C G (volume V > 0,
// the rest volume).
Eigen::Matrix3d fixed_corotated_stress(const Eigen::Matrix3d& F, double mu, double lambda);
Matrix9d fixed_corotated_tangent(const Eigen::Matrix3d& F, double mu, double lambda);
void fixed_corotated_element(const Matrix43d& grad, double volume, double mu, double lambda,
                             const Vector12d& x, Vector12d& f_e, Matrix12d* K_e_t);

// The neo-Hookean material: P = mu (F - F^-T) + lambda ln J F^-T, its tangent
//   dP_ij/dF_kl = mu d_ik d_jl + (mu - lambda ln J) Finv_jk Finv_li + lambda Finv_ji Finv_lk,
// and one tet's force and tangent as above. NaN where J <= 0.
Eigen::Matrix3d neo_hookean_stress(const Eigen::Matrix3d& F, double mu, double lambda);
Matrix9d neo_hookean_tangent(const Eigen::Matrix3d& F, double mu, double lambda);
void neo_hookean_element(const Matrix43d& grad, double volume, double mu, double lambda,
                         const Vector12d& x, Vector12d& f_e, Matrix12d* K_e_t);

// The tangent dP/dF of `material` at F (the co-rotated linear one with its rotation gradient).
Matrix9d material_tangent(CorotMaterial material, const Eigen::Matrix3d& F, double mu,
                          double lambda);

// Strong ellipticity of a material tangent C: the smallest eigenvalue of the acoustic tensor
// Q(n)_ik = sum_jl C(i + 3 j, k + 3 l) n_j n_l (Pa) over unit directions n (sampled on 600
// directions, then refined by projected gradient descent; n_min gets the minimiser). > 0: every
// rank-one (plane-wave) perturbation a (x) n costs energy. <= 0: the material has lost
// ellipticity there — a deformation localised across planes normal to n costs none, so a fine
// enough mesh has a singular tangent whatever its boundary conditions.
// The co-rotated linear material loses it under moderate compression: in its pressure term
// lambda tr(S - I) the rotation gradient multiplies the (compressive) stress, the initial-stress
// term of the shear waves. Under hydrostatic compression F = s R the minimum is
// mu - p / (2 s) with p = -(2 mu + 3 lambda)(s - 1): zero at s = (2 mu + 3 lambda) /
// (4 mu + 3 lambda), i.e. det F = 0.82 for nu = 0.45 (tests/fem).
double acoustic_tensor_min(const Matrix9d& C, Eigen::Vector3d* n_min = nullptr);

// Lame constants of Young's modulus E (Pa) and Poisson's ratio nu.
inline void lame(double E, double nu, double& mu, double& lambda) {
  mu = E / (2 * (1 + nu));
  lambda = E * nu / ((1 + nu) * (1 - 2 * nu));
}

}  // namespace palplab::engine
