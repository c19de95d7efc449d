#pragma once
// The inside of a Scene (for the prototype factory, tests and benchmarks; participants use
// scene.hpp only). One model per scene, chosen by `kind`; a switch per step, no virtual calls.
#include <memory>
#include <string>
#include <vector>

#include "engine/haptics/scene.hpp"
#include "engine/mesh/rings.hpp"
#include "engine/models/refinement.hpp"
#include "engine/models/ring_model.hpp"
#include "engine/solvers/integrators.hpp"
#include "engine/solvers/sleeping.hpp"
#include "engine/spatial/octree.hpp"

namespace palplab::engine {

enum class ModelKind { penalty, ring, mass_spring };
const char* to_string(ModelKind k);

struct Cues {
  bool haptic = true;
  bool visual_deformation = true;
  bool audio = false;
};

struct MassSpringScene {
  AdaptiveMassSpring model;
  Integrator integrator = Integrator::backward_euler;
  IntegratorWorkspace ws;
  ActiveSet act;
  SleepParams sleep;
  std::vector<std::uint8_t> scratch;
  bool refine = true;  // adaptive refinement on
  RefineParams refine_params;
  double refine_force = 1.0;          // N: refine around the touched node from this force on
  bool substep = true;                // sub-step h/2^l while refined (Eq 5.18)
  int refined_node = -1;              // model node last refined around
  std::vector<int> surface_to_model;  // surface node -> model node (identity for surfaces)
  // Integration scope: only nodes within scope_radius (m, rest distance, reached through springs)
  // of the contact node may wake; 0 = whole model. Held nodes act as fixed boundary.
  double scope_radius = 0.0;
  int scope_max_nodes = 1 << 30;  // cap on the scope (nearest rings first)
  double patch_radius = 0.01;     // m, radius of the probe face (the contact patch)
  int patch_center = -1;          // model node the patch was built around
  long patch_nodes_version = -1;  // model node count the patch was built for
  std::vector<std::uint8_t> patch_mark;
  int scope_center = -1;
  std::vector<std::uint8_t> in_scope;
  std::vector<int> scope_nodes, bfs;
};

struct SceneImpl {
  std::string prototype;
  ModelKind kind = ModelKind::penalty;
  double dt = 1e-3;  // s
  Cues cues;
  double contact_k = 800.0;      // N/m, penalty (A, B) or device coupling (C)
  double contact_radius = 0.01;  // m, how close to a surface node a contact may start
  // A step is treated as diverged (SceneStats::nan_detected, model reset to rest) when the force
  // or the touched node's displacement exceed these (or are not finite).
  double divergence_force = 100.0;       // N (palpation forces are a few N)
  double divergence_displacement = 0.5;  // m
  // The device's peak force (N): a rendered force is clamped to it (event force_limited).
  double force_limit = 8.5;
  // Passivity observer: energy the scene returned to the hand beyond what the hand put in
  // during one contact (J) before the event energy_injected.
  double energy_threshold = 0.005;
  SceneGeometry geom;
  std::shared_ptr<const spatial::Octree> octree;         // over geom.V (rest)
  std::shared_ptr<const mesh::RingTable> surface_rings;  // first ring of the surface, for walking
  std::vector<Thresholds> thresholds;                    // per region
  Thresholds default_thresholds;                         // for unlabelled contacts

  RingModel ring;      // kind == ring
  MassSpringScene ms;  // kind == mass_spring

  // --- state ---
  long step_index = 0;
  double t = 0.0;
  bool engaged = false;  // tracking a contact node (device below the rest tangent plane)
  bool contact = false;  // force is being exchanged
  int node = -1;         // surface node of the contact
  double peak_force = 0.0;
  bool reached[3] = {false, false, false};  // ST, MPF, SFT in this contact
  bool limited = false, energy_flagged = false, device_bad = false;
  double energy_out = 0.0;  // J: work of the rendered force on the hand in this contact
  Eigen::Vector3d x_prev = Eigen::Vector3d::Zero(), f_prev = Eigen::Vector3d::Zero();
  std::vector<Event> events;
  Sample last;
  SceneStats counters;
};

}  // namespace palplab::engine
