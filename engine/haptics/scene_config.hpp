#pragma once
// engine::SceneConfig: everything a scene is built from, with every default in one place (the
// member initialisers here and in the parameter structs they hold). A prototype file is read into
// one (prototypes::load_prototype, docs/FORMATS.md), a study phase edits it
// (apply(SceneOverrides)), engine::make_scene builds the Scene. A tool or test that wants a variant
// (another scope, sleeping off, another integrator) edits the config: there is no other door into
// a scene.
#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "engine/haptics/scene.hpp"
#include "engine/models/fem_formulation.hpp"
#include "engine/models/refinement.hpp"
#include "engine/models/ring_model.hpp"
#include "engine/solvers/integrators.hpp"
#include "engine/solvers/sleeping.hpp"

namespace palplab::engine {

// Where the mesh comes from: a generator of engine/mesh or a mesh file.
struct MeshSource {
  std::string generator = "tract";  // tract | model_c | stomach | sphere
  int vertices = 1500;
  std::uint64_t seed = 0;  // 0 = the reference shape
  std::string file;        // absolute path of a mesh file (instead of a generator)
  std::string key() const;
};

// The tissue of a deformable model (engine/mesh/materials.json).
struct MaterialConfig {
  std::string tissue;  // empty: the mesh's tissue attribute (tet meshes) or "soft tissue"
  std::optional<double> youngs_modulus;  // Pa, overrides the table
  std::optional<double> density;         // kg/m^3, overrides the table
  double thickness = 0.005;              // m, membrane thickness of a surface model
  double rayleigh_beta = 0.002;          // s, stiffness-proportional damping kd = beta ks
};

// What holds the organ: an elastic foundation per unit area and pinned nodes.
struct SupportConfig {
  double modulus = 0.0;        // N/m^3, foundation stiffness per area of the surface it holds
  double damping = 0.0;        // N s/m^3
  std::string fixed_region;    // every node of this region is pinned
  double fixed_z_below = 0.0;  // m above the lowest point: nodes below are pinned (0 = none)
};

// The device–tissue coupling.
struct ContactConfig {
  double stiffness = 500.0;    // N/m: penalty (A, B) or the device coupling (deformable models)
  double patch_radius = 0.01;  // m, radius of the probe face (deformable models)
  double force_limit = 8.5;    // N, the device's peak force (a common desktop device)
  // mass_spring: the probe face as a disc of quadrature points (engine/models/contact_pad.hpp)
  // instead of the vertex pads (model key "contact_pad": "disc").
  bool disc_pad = false;
};

// Which nodes a deformable model integrates.
struct ScopeConfig {
  Scope rings = Scope::rings;  // ring model: rings | octant | whole
  double radius = 0.0;         // m, integration scope around the contact (0 = whole model)
  int max_nodes = 1 << 30;     // cap on the scope (nearest rings first)
  // Mass-spring: outside the scope, the whole model's linear static response to the contact
  // force (engine/solvers/far_field.hpp) instead of rest.
  bool linear_exterior = true;
  // How the linear exterior follows a moved scope (engine/solvers/far_field.hpp, FarFieldMode):
  // worker (true): solved beside the haptic loop and adopted exterior_latency_steps later —
  // deterministic in lock-step, asynchronous in a real-time loop (Scene::set_realtime);
  // false: solved inside the step that moved the scope (a step of 3-25 ms on Model-C).
  bool exterior_worker = true;
  int exterior_latency_steps = 20;
};

struct RefinementConfig {
  bool enabled = false;
  RefineParams params;
  double threshold_force = 1.0;  // N: refine around the touched node from this force on
  bool substep = true;           // sub-step h / 2^level while refined
};

// The scene's numerical safety net (hard-cases issue): beyond these a step is a divergence.
struct WatchdogConfig {
  double divergence_force = 100.0;       // N (palpation forces are a few N)
  double divergence_displacement = 0.5;  // m
  double energy_threshold = 0.005;       // J returned to the hand beyond what it put in
};

// Model "fem" (prototype D; engine/models/fem_scene_model.cpp, docs/FORMATS.md). The tissue
// comes from MaterialConfig (per tet from the tissue table), the pinned nodes from SupportConfig.
struct FemConfig {
  FemFormulation formulation = FemFormulation::linear;
  double rayleigh_alpha = 1.0;       // 1/s, mass-proportional damping
  double rayleigh_beta = 0.001;      // s, stiffness-proportional damping
  bool lumped_mass = true;           // false: consistent mass (linear, corotational)
  bool exact_jacobian = true;        // corotational: consistent tangent; false: stiffness warping
  std::string operational_region;    // condensed: the region the device works on (required)
  double operational_radius = 0.01;  // m: tets within this distance of the region are solved
  double update_rate_hz = 60.0;      // corotational_multirate: deformation updates per second
  bool multirate_deterministic = false;  // wait for the worker: reproducible, may block
};

// Model "needle" (prototype N; engine/models/needle_model.cpp, docs/FORMATS.md). Needle
// parameters per tissue come from the material table (engine/mesh/materials.json).
struct NeedleSceneConfig {
  std::string tool = "finger";          // the tool at the start and after reset: finger | needle
  Eigen::Vector3d axis{0.0, 1.0, 0.0};  // stylus axis at the start (unit after reading)
  int target_tissue = 107;              // tissue attribute of the target (membrane)
  double finger_radius = 0.008;         // m, radius of the fingertip's contact
  double stiffening = 3.0;              // 1, exponential strain stiffening of soft tissue
  double bone_stiffness = 20000.0;      // N/m, the finger on bone through squeezed tissue
  double log_resolution = 1e-4;         // m, a tip_to_target event when it changed this much
};

struct Cues {
  bool haptic = true;
  bool visual_deformation = true;
  bool audio = false;
  bool transparency = false;  // needle scenes: soft tissue drawn see-through (tip visible)
};

struct SceneConfig {
  std::string id;           // "A", "C1", ...
  std::string scene;        // e.g. "bovine_reproductive_tract"
  std::string description;  // free text
  std::string source;       // the file it was read from ("" when built in code), for messages
  MeshSource mesh;
  std::string model = "penalty";  // a registered model kind (engine/models/model.hpp)
  RingParams ring;                // model "ring"
  FemConfig fem;                  // model "fem"
  NeedleSceneConfig needle;       // model "needle"
  MaterialConfig material;        // deformable models
  SupportConfig support;
  Integrator integrator = Integrator::backward_euler;
  SolverConfig solver;
  SleepParams sleeping;
  ScopeConfig scope;
  RefinementConfig refinement;
  ContactConfig contact;
  WatchdogConfig watchdog;
  Cues cues;
  double dt = 1e-3;                               // s, haptic step
  Thresholds default_thresholds{2.0, 2.5, 3.0};   // N, for regions the file does not list
  std::map<std::string, Thresholds> thresholds;   // region -> limits; "*" = every region
  std::optional<Eigen::Vector3d> start_position;  // m; default 5 cm in front of the organ
};

// Applies a study phase's overrides (cues, thresholds, integrator). Throws palplab::InputError
// (naming cfg.source) for an unknown region or integrator.
void apply(SceneConfig& cfg, const SceneOverrides& overrides);

// Builds the scene (meshes and their precomputation are cached per process and mesh source).
// Throws palplab::InputError for a config that cannot be built (unknown model kind, bad mesh).
Scene make_scene(const SceneConfig& cfg);

// Region names of a mesh source without building a scene (generators: fixed; files: read).
const std::vector<std::string>& mesh_region_names(const MeshSource& m);
// The regions of a mesh source with no vertex on its surface (a tet mesh's inner tissues: the
// shoulder's bones, a file's inner regions): they can be reached by a needle, never touched.
// Empty for the surface generators.
std::vector<std::string> mesh_inner_region_names(const MeshSource& m);

}  // namespace palplab::engine
