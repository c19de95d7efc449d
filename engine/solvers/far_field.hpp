#pragma once
// The exterior of a local integration scope as the linear, quasi-static response of the whole
// mass-spring model at rest (prototype C).
//
// A scope integrates the nodes near the contact; the rest of the organ used to be held at rest,
// a rigid wall 3 cm away that made the press 19-26 % too stiff (bench `sleeping`). Here the
// exterior follows the whole model's linear static response to the current contact force F:
//   K g = l,   u_exterior = |F| g,
// K: the stiffness of every non-fixed coarse node at rest (springs ks d d^T, support home_ks;
// fixed nodes removed), l: a unit load along -n spread over the contact patch by its weights.
// With the exterior's true displacement prescribed on the scope's boundary, the scope's own
// (nonlinear, dynamic) solution is the whole model's in the quasi-static linear limit: the
// exterior's compliance without integrating it. K is factorised once per model (sparse LDLT),
// g costs one solve when the scope is re-centred; a step adds |exterior| 3-vectors.
// Vectors are 3 #coarse, node-major; nodes beyond `nodes` (refinement) are not part of it.
// A .psim file stores the factorisation (far_field_save; the LdltFactor serialisation of
// engine/models/stored_factor.hpp) tagged with a SHA-256 of every input of K; a build from the
// same system restores it instead of factorising, and solves bit-identically.
#include <Eigen/SparseCore>
#include <string>
#include <vector>

#include "engine/models/mass_spring.hpp"
#include "engine/solvers/ldlt_factor.hpp"

namespace palplab::engine {

struct FarField {
  long nodes = 0;           // coarse nodes K was assembled for
  std::vector<int> dof;     // #nodes: first dof of a node, -1 = fixed
  LdltFactor factor;        // P K P^T = L D L^T (#dofs square)
  Eigen::VectorXd load, g;  // #dofs: the unit load and its displacement (m/N)
  Eigen::VectorXd tmp;      // #dofs: solve buffer
  double factor_ms = 0.0;   // time the factorisation (or its restoring) took
  bool restored = false;    // the factorisation came from a stored blob
  double solve_ms = 0.0;    // time the last far_field_solve took (wall, ms)
  bool ready() const { return nodes > 0; }
};

// Assembles K at rest over sys's nodes and factorises it. Throws std::runtime_error when K is
// singular (a part of the model with neither support nor fixed node). `stored` (nullptr = none):
// a far_field_save blob; used (ff.restored) only when it was made from a system with the same
// nodes, rest positions, fixed nodes, support and springs, and is well formed; else ignored.
void far_field_build(const MassSpringSystem& sys, FarField& ff,
                     const std::string* stored = nullptr);

// ff's factorisation (built for sys) as bytes for a .psim file.
std::string far_field_save(const MassSpringSystem& sys, const FarField& ff);

// g for a unit force along `dir` (the direction the tissue is pushed) shared by the patch
// `nodes` with `weights` (nodes >= ff.nodes are left out and the weights renormalised).
void far_field_solve(FarField& ff, const std::vector<int>& nodes,
                     const std::vector<double>& weights, const Eigen::Vector3d& dir);

}  // namespace palplab::engine
