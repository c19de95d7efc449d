#pragma once
// Inverse-stiffness contact. With C = K_ff^-1 (the compliance of the constrained
// body), the columns of C for the touchable surface nodes are precomputed (3 sparse solves per
// node). At run time a contact prescribes the displacement of some touchable nodes along given
// directions n_k (a whole node = its three axes); the contact forces f_k n_k solve the small
// dense system
//   (N^T C_bb N) lambda = d - N^T u0_b,   u = u0 + C_:b N lambda,
// which is the original work's f_contact = (K^-1_bb)^-1 (d_contact - K^-1_ab^T f_nocontact) with u0
// = C f_nc the displacement of the non-contact load. The body stays free (no friction) in the
// directions not prescribed. Costs O(k^3 + 3#V k) for k prescribed directions instead of a sparse
// solve.
#include <Eigen/Core>
#include <vector>

#include "engine/solvers/fem_static.hpp"

namespace palplab::engine {

struct ContactCompliance {
  std::vector<int> touch_nodes;  // the touchable nodes (free, not fixed)
  std::vector<int> slot;         // #V: index into touch_nodes or -1
  Eigen::MatrixXd C;             // 3#V by 3#touch: displacement per unit force (m/N)
  Eigen::VectorXd u0;            // 3#V displacement under the non-contact load (m)
  double precompute_ms = 0;
};
// Throws std::invalid_argument if a touch node has a fixed dof.
void contact_compliance_precompute(const StaticSolver& s, const std::vector<int>& touch_nodes,
                                   const Eigen::VectorXd& f_nocontact, ContactCompliance& c);

// One prescribed displacement: node (a touch node), unit direction (world), displacement (m).
struct ContactConstraint {
  int node = -1;
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
  double displacement = 0;
};
struct ContactSolution {
  Eigen::VectorXd force;  // #constraints: force along each direction applied to the body (N)
  Eigen::VectorXd u;      // 3#V displacement field (m)
};
// Throws std::invalid_argument for a node that is not touchable.
void contact_solve(const ContactCompliance& c, const std::vector<ContactConstraint>& contact,
                   ContactSolution& out, bool want_field = true);

}  // namespace palplab::engine
