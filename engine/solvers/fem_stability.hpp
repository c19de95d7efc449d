#pragma once
// Stability of an equilibrium of the co-rotational FEM (issue 12: why the 4 N body curve stops):
// the eigenvalues of the tangent closest to zero with their modes, where a mode lives, how much
// work the load does on it, and where the material has lost strong ellipticity.
//
// At a regular point of the load path the tangent K_t (free dofs) is nonsingular. Where an
// eigenvalue crosses zero with mode phi, the path has
//   a limit point   when f . phi != 0 (the load cannot be raised: the dead-load Newton stalls,
//                   an arc-length method would turn the path), or
//   a bifurcation   when f . phi = 0 (another equilibrium branch crosses; the load can go on on
//                   the primary branch, which is then unstable).
// A singular tangent that comes from the material (loss of ellipticity in a region) has modes
// localised in that region, at the scale of the mesh, and appears at a lower load on a finer mesh
// (it resolves shorter waves): neither method gives a mesh-independent continuation.
#include <Eigen/Core>
#include <vector>

#include "engine/solvers/fem_assembly.hpp"
#include "engine/solvers/fem_corotational.hpp"
#include "engine/solvers/fem_static.hpp"

namespace palplab::engine {

// The `count` eigenpairs of the symmetric s.K_ff with the smallest |eigenvalue| (N/m), by
// subspace inverse iteration with the factorisation in s (any kind; LDL^T for an indefinite
// matrix) and Rayleigh-Ritz, from a fixed pseudo-random start. values ascending by |value|;
// vectors: #free by count, unit 2-norm. residual: the largest |K phi - value phi| / |K|_max
// (the largest |diagonal entry|) reached; iterations: those taken (<= max_iterations, stops
// when residual <= tolerance).
struct LowestModes {
  Eigen::VectorXd values;
  Eigen::MatrixXd vectors;
  int iterations = 0;
  double residual = 0;
};
LowestModes lowest_modes(const StaticSolver& s, int count = 3, int max_iterations = 60,
                         double tolerance = 1e-9);

// Per-tet strong ellipticity of the co-rotational material at positions x (3#V):
// min over directions of the acoustic tensor's smallest eigenvalue (Pa; acoustic_tensor_min),
// divided by the tet's shear modulus mu (1 at rest; <= 0: ellipticity lost). Rigid tets: 1.
std::vector<double> ellipticity_margin(const FemSystem& sys, const Eigen::VectorXd& x,
                                       CorotMaterial material = CorotMaterial::corotated_linear);

// Where a mode (3#V, fixed dofs zero) lives, against a press at `point` with radius `radius`
// and load f (3#V):
struct ModeShape {
  double load_cosine = 0;          // f . phi / (|f| |phi|): 0 = bifurcation, else limit point
  double max_node_distance = 0;    // m, from the press point to the node of largest |phi_i|
  double near_press_fraction = 0;  // share of |phi|^2 on nodes within 2 radii of the point
  double participation = 0;        // (sum |phi_i|^2)^2 / sum |phi_i|^4: nodes the mode spreads over
  // share of |phi|^2 on the nodes of tets with margin <= 0 (ellipticity_margin)
  double non_elliptic_fraction = 0;
};
ModeShape mode_shape(const FemSystem& sys, const Eigen::VectorXd& phi, const Eigen::VectorXd& f,
                     const Eigen::Vector3d& point, double radius,
                     const std::vector<double>& margin);

}  // namespace palplab::engine
