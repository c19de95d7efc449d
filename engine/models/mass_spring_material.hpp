#pragma once
// Mass-spring parameters from a material and the rest geometry — never per vertex — so that a
// press gives the same force on a coarse and on a fine mesh of the same organ (to first order).
//
// Springs: van Gelder (1998, "Approximate simulation of elastic membranes by triangulated spring
// meshes", J. Graphics Tools 3(2):21–42): the spring on edge e gets the stiffness
//   k_e = sum over the elements at e of  E |el| / |e|^2
// with |el| the tet volume (volume model, E in Pa) or the triangle area times a membrane
// modulus c = E t (surface model, c in N/m). A mass-spring network cannot represent Poisson's
// ratio; nu is not used (documented limitation; the FEM model is the reference that does).
// Damping: kd = beta k_e (stiffness-proportional Rayleigh damping, beta in s).
// Masses: density x volume lumped to the nodes (tet: V/4 per corner; surface: rho t A/3).
// Support: an elastic foundation (Winkler) of modulus kappa (N/m^3) under the surface: node i
// gets a zero-rest-length home spring kappa A_i (A_i its lumped surface area), damped by
// beta_s kappa A_i — the support per unit area is a property of the organ's attachment, so the
// total support does not grow with the vertex count.
//
//   X  #V by 3 rest positions (m);  T  #T by 4 tets;  F  #F by 3 surface triangles
#include <Eigen/Core>

#include "engine/models/mass_spring.hpp"

namespace palplab::engine {

// Springs on the unique edges of T; E_tet #T Young's moduli (Pa). `edges`: unique_edges(T) if
// the caller has them (a scene mesh's model_E; sorting them again was 20 % of loading prototype
// C from a .psim file); used only when they are exactly those edges (checked), else computed.
Springs tet_springs(const RowMatX3d& X, const RowMatX4i& T, const Eigen::VectorXd& E_tet,
                    double beta, const RowMatX2i* edges = nullptr);
// Springs on the unique edges of F; c_face #F membrane moduli (N/m).
Springs membrane_springs(const RowMatX3d& X, const RowMatX3i& F, const Eigen::VectorXd& c_face,
                         double beta);
// #V lumped masses (kg): density_tet #T (kg/m^3).
Eigen::VectorXd tet_lumped_mass(const RowMatX3d& X, const RowMatX4i& T,
                                const Eigen::VectorXd& density_tet);
// #V lumped surface areas (m^2): A_f/3 to each corner.
Eigen::VectorXd lumped_area(const RowMatX3d& X, const RowMatX3i& F);
// #F membrane share of boundary face f of a tet model: c_f = E_t V_t / (n_t A_f) with
// t = tet_of[f] and n_t its number of boundary faces, so that c_f A_f / |e|^2 summed over the
// tet's boundary faces is exactly tet t's term of van Gelder's sum on each of its edges (the
// part of the tet that refining face f re-divides; engine/models/refinement.hpp).
Eigen::VectorXd boundary_membrane(const RowMatX3d& X, const RowMatX4i& T, const RowMatX3i& F,
                                  const Eigen::VectorXi& tet_of, const Eigen::VectorXd& E_tet);

}  // namespace palplab::engine
