#pragma once
// Vertex-based visio-haptic ring model (prototype B).
//
// Fixed nodes X_fixed (rest, never move) and deformable nodes X. While the haptic contact point
// pushes node p with force F_push (N, the force the hand applies, pointing into the organ):
//   p' = p + m1 F_push,  first ring q' = q + m2 F_push,  second ring r' = r + m3 F_push
// (Eq 4.2–4.4 with m1 > m2 > m3 > 0 in m/N: displacement along the push, deepest at p — the
// original's negative step sizes act on the force on the hand, which points the other way).
// Every other displaced node is pulled home by a damped zero-rest-length spring (Eq 4.11):
//   f = ks (x_fixed - x) - kd v, integrated per node by backward Euler (unconditionally stable).
// The haptic force is computed by the scene (Hooke's law on the penetration, as in A).
//
// Scope (which nodes the haptic loop updates): rings = only displaced/moving nodes
// (tracked in an active list), octant = also every node of the touched node's octree leaf,
// whole = every node every step (the original's "whole model" mode).
#include <memory>
#include <string>
#include <vector>

#include "engine/mesh/rings.hpp"
#include "engine/models/mass_spring.hpp"
#include "engine/spatial/octree.hpp"

namespace palplab::engine {

enum class Scope { rings, octant, whole };
Scope scope_from_string(const std::string& s);  // throws std::invalid_argument
const char* to_string(Scope s);

struct RingParams {
  double m1 = 4e-3, m2 = 2.5e-3, m3 = 1e-3;  // m/N
  double node_mass = 1e-3;                   // kg, per deformable node (home-spring dynamics)
  double home_ks = 20.0;                     // N/m
  double home_kd = 0.2;                      // N s/m
  double rest_tol = 1e-7;                    // m: below this (and slow) a node is back home
};

struct RingModel {
  RowMatX3d X_fixed, X, V;  // #V by 3 (m, m/s)
  // The ring tables, shared with the scene's prepared mesh (or a .psim file's): read-only, and
  // copying them was a third of building B's model (perf). Never null after make_ring_model.
  std::shared_ptr<const mesh::RingTable> rings;
  RingParams params;
  Scope scope = Scope::rings;
  const spatial::Octree* octree = nullptr;  // for Scope::octant (owned by the scene)
  std::vector<int> active;                  // displaced or moving nodes
  std::vector<std::uint8_t> is_active, pressed;
  std::vector<double> coef;  // scratch: the placement coefficient of each pressed node (m/N)
  std::vector<int> placed;   // scratch: the nodes placed in this step
  long last_updated = 0;     // nodes visited in the last step (for benchmarks)
};

RingModel make_ring_model(const RowMatX3d& V, const mesh::Edges& E, const RingParams& p);
// The same with the ring tables given (mesh::compute_rings(#V, E) of the same mesh: a scene's
// prepared mesh holds them, and a .psim file stores them), shared, not copied. Throws
// std::invalid_argument for null tables or tables of another mesh.
RingModel make_ring_model(const RowMatX3d& V, std::shared_ptr<const mesh::RingTable> rings,
                          const RingParams& p);

// One haptic step of h seconds. node = touched node (-1 without contact); push = force of the
// hand on the organ (N).
void ring_step(RingModel& m, int node, const Eigen::Vector3d& push, double h);
// The same with the push shared by up to three touched nodes (a contact point on a face):
// nodes[k] with weight w[k] (>= 0, sum 1; node -1 or weight 0 = unused). Each node's rings are
// placed as above and the displacements add with the weights, scaled so the contact point
// (sum_k w_k x_k) moves by exactly m1 push, as a touched node does. When the contact point slides
// across an edge (the weight of the vertex it leaves goes to 0) the shape changes continuously.
void ring_step(RingModel& m, const int nodes[3], const double w[3], const Eigen::Vector3d& push,
               double h);

// Back to rest (all nodes home, nothing active).
void ring_reset(RingModel& m);

// Largest |x - x_fixed| (m).
double ring_max_displacement(const RingModel& m);

}  // namespace palplab::engine
