#pragma once
// THE SCENE CONTRACT: what a study runner (protocols) and a virtual or real participant see of a
// simulator prototype. Names here are stable: fields and functions may be added, never renamed.
//
// A Scene is built by engine::make_scene(SceneConfig) (engine/haptics/scene_config.hpp), usually
// through palplab::prototypes::build_scene(prototype_json_path, overrides). It is
// driven in lock-step: step(device_position) advances exactly one haptic step (1 ms of simulated
// time by default; the model may sub-step internally) and returns what the simulator RENDERS —
// everything a participant may perceive and nothing else — plus the events of that step for
// logging. Deterministic and bit-reproducible: no threads, no clocks, no random numbers inside.
//
// Units: SI everywhere (m, N, s, kg). The device position is the haptic contact point (HCP) in
// the organ's frame (m). Forces are the force the simulator applies to the hand (N): pressing
// into the organ yields a force pointing back out of it.
#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "engine/mesh/types.hpp"

namespace palplab::spatial {
struct Octree;
}

namespace palplab::engine {

struct SceneConfig;

// Force limits of one anatomical part (N). ST < SFT; the audio cue sounds from ST on, MPF is the
// target not to exceed, SFT the hard stopping threshold.
struct Thresholds {
  double st = 0.0;   // sound threshold (N)
  double mpf = 0.0;  // maximum palpation force (N)
  double sft = 0.0;  // stopping force threshold (N)
};

// Contacts separated by less than this are one touch in the event log (contact_start ..
// contact_end, the threshold events once per touch); the physics knows no such thing.
inline constexpr double kTouchGap = 0.01;  // s

enum class EventKind {
  contact_start,  // value: 0
  contact_end,    // value: peak force magnitude of the touch (N); t: when the contact was lost
                  // (the first step without it), logged once kTouchGap has passed without
                  // contact (a touch open at the session end has none)
  st_reached,     // value: force magnitude at the crossing (N); region: contact region
  mpf_reached,
  sft_reached,
  // Watchdog (value as noted). A contact's force above the device's limit is clamped to it:
  force_limited,    // value: the unclamped force (N); once per contact
  divergence,       // value: the offending force (N), -1 if not finite; the model went to rest
  energy_injected,  // value: energy the scene has returned to the hand beyond what it got (J),
                    // once per contact (passivity observer; the scene is not passive)
  device_invalid,   // value: 0; a non-finite or absurd (> 10 m) device position: no contact
  // Tools and the needle (model "needle", prototype N; docs/FORMATS.md "Needle"). Tissue events:
  // region = the tissue's region index (region names of a needle scene are its tissue names),
  // value = the tissue attribute (100 skin, 101 soft tissue, 107 membrane, 200+ bone, 300+ muscle).
  tool_changed,     // value: 0 finger, 1 needle (Scene::set_tool)
  insertion_start,  // value: the insertion's number (1, 2, ...): the tip passed the skin surface
  tissue_entered,   // the needle tip entered the tissue (puncture, or re-entry on withdrawal)
  tissue_left,      // the tip left the tissue
  bone_contact,     // the tip started pressing on bone (region/value: the bone)
  target_reached,   // the tip entered the target tissue (once per insertion)
  tip_to_target,    // value: distance of the tip to the target (m), logged when it changed by
                    //   the scene's needle.log_resolution since the last such event
  // A contact that began with the device already inside the organ (its first position after
  // reset, or after device_invalid, is inside): the proxy starts at the closest surface point.
  contact_inside,  // value: the depth (m) the force starts from
  // The device moved farther than kMaxDeviceStep in one step (no hand does: a bridge's glitch,
  // a tracker that lost the hand): its path is not taken as a motion through the organ, and the
  // contact is found anew from where it is (as after device_invalid).
  device_jump,  // value: the distance jumped (m)
};
// The most a device moves in one haptic step before it counts as a jump (m): 5 cm in 1 ms is
// 50 m/s, ten times a fast hand.
inline constexpr double kMaxDeviceStep = 0.05;
// Frames per second of the drawn picture that Rendered::visible_volume follows.
inline constexpr double kVisibleFrameRate = 60.0;
// The farthest a device position may be from the device origin (m, per axis): beyond it the
// position is invalid (device_invalid; a UDP datagram holding one is malformed), as in a trace
// file or a device-sim script. Organs are centimetres across.
inline constexpr double kMaxDevicePosition = 10.0;
const char* to_string(EventKind k);

// An event of one step. Events are for LOGGING, not perception: a participant model must use
// only the fields of Rendered (a threshold event fires whether or not a cue renders it).
struct Event {
  double t = 0.0;  // s, simulated time of the step in which it happened
  EventKind kind = EventKind::contact_start;
  int region = -1;     // index into SceneGeometry::region_names; -1 = no labelled region
  int node = -1;       // contact node (surface node index)
  double value = 0.0;  // see EventKind
};

// What the simulator renders in one haptic step.
struct Rendered {
  double t = 0.0;                                   // s, simulated time at the end of the step
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  // N, force on the hand (0 if haptics off)
  bool contact = false;                             // the HCP touches the organ
  int contact_node = -1;    // nearest surface node of the contact; -1 without contact
  int contact_region = -1;  // region of the contact node; -1 = none/unlabelled
  // Visible deformation of the touched region (m): displacement magnitude of the contact node
  // from its rest position as drawn. 0 for prototype A or when the visual-deformation cue is off.
  double visible_deformation = 0.0;
  // The volume the drawn surface is pushed in by (m^3): the sum over the surface vertices of
  // their rest area times their inward displacement, updated at the display's frame rate
  // (kVisibleFrameRate) and held between frames. Computed only when asked for
  // (Scene::set_visible_volume); otherwise, and when visible_deformation is 0, it is 0.
  double visible_volume = 0.0;
  bool audio = false;  // the audio cue sounds (force >= ST of the contact region, cue on)
  // Needle scenes with the transparency cue on (soft tissue drawn see-through): the distance of
  // the needle tip to the target (m) and the tissue attribute at the tip; -1 when not shown.
  double visible_tip_to_target = -1.0;
  int visible_tip_tissue = -1;
  // Events of this step; the span stays valid until the next call to step() or reset().
  std::span<const Event> events;
};

// One logged sample per step (the architecture's Sample{t, x, F, contact_node}).
struct Sample {
  double t = 0.0;                               // s
  Eigen::Vector3d x = Eigen::Vector3d::Zero();  // m, device position given to step()
  Eigen::Vector3d F = Eigen::Vector3d::Zero();  // N, force on the hand
  int contact_node = -1;
};

// Rest geometry for the participant's exploration (surface only; the tet interior is hidden).
// The closed surface of every tissue of a layered tet scene (needle scenes), so that a renderer
// can draw bone and target through a transparent skin: own vertices per tissue (#S by 3, m, at
// rest), faces (#G by 3, ccw seen from outside the tissue) and each vertex's region index (the
// tissue's region in SceneGeometry::region_names, -1 = unnamed).
struct TissueSurfaces {
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> V;
  Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor> F;
  std::vector<int> vertex_region;
  // Regions of the soft tissues (neither rigid nor the target): what the transparency cue makes
  // see-through.
  std::vector<int> soft_regions;
};

struct SceneGeometry {
  mesh::Positions V;                      // #V by 3 rest positions (m)
  mesh::Positions N;                      // #V by 3 unit outward normals
  mesh::Faces F;                          // #F by 3 faces (ccw outside)
  std::vector<int> vertex_region;         // #V region index per vertex, -1 = unlabelled
  std::vector<std::string> region_names;  // e.g. "ovary_left", "body", "cervix"
  Eigen::Vector3d start_position = Eigen::Vector3d::Zero();  // m, where the HCP starts

  int region_index(const std::string& name) const;  // -1 if unknown
  // Mean rest position of the region's vertices (m). Throws std::out_of_range if unknown,
  // InputError if it has no surface vertex (an inner tissue of a tet mesh).
  Eigen::Vector3d region_centroid(const std::string& name) const;
  // Surface node nearest to p (octree search).
  int nearest_node(const Eigen::Vector3d& p) const;
  // Surface node of the region nearest to its centroid (the "press here" node).
  int region_node(const std::string& name) const;

  std::shared_ptr<const spatial::Octree> octree;  // search structure over V (shared, immutable)
  // Needle scenes: the tissues' surfaces inside the skin (static); nullptr for other models.
  std::shared_ptr<const TissueSurfaces> tissues;
};

// What a study phase may change of a prototype without editing its file.
struct SceneOverrides {
  std::optional<bool> haptic;                    // render the force on the hand
  std::optional<bool> visual_deformation;        // draw the live deformation
  std::optional<bool> audio;                     // sound at ST
  std::optional<bool> transparency;              // needle scenes: soft tissue see-through
  std::map<std::string, Thresholds> thresholds;  // region name -> limits (N); "*" = every region
  std::optional<std::string> integrator;         // "symplectic_euler" | "backward_euler" | "rk4"
};

// Counters a researcher or a benchmark may want (not perceivable).
struct SceneStats {
  long nodes = 0;    // simulated nodes now (incl. refinement nodes)
  long springs = 0;  // springs now
  long coarse_nodes = 0;
  long coarse_springs = 0;
  // Rows of current_surface() that are coarse surface vertices (in the geometry's order); the
  // refinement nodes follow them (a renderer marks those). Models that leave it 0 get
  // coarse_nodes.
  long surface_coarse_nodes = 0;
  long new_nodes_max = 0;       // most refinement nodes present at once since reset
  long new_springs_max = 0;     // most refinement springs present at once since reset
  double total_mass = 0.0;      // kg, now
  double max_rest_error = 0.0;  // m, largest |x - x_rest| over the simulated nodes now
  long awake_nodes = 0;         // nodes integrated in the last step
  int level = 0;                // current refinement level (0 = coarse)
  // A non-finite or diverged state (force > 100 N or touched-node displacement > 0.5 m on a
  // deformable model) was found since reset; the model was put back to rest and that step
  // rendered no force (event `divergence`). A rigid model is never reset.
  bool nan_detected = false;
  long divergences = 0;    // how many times since reset
  long force_limited = 0;  // steps whose force was clamped to the device limit
  // Model-specific facts as a JSON object text ("" = none), e.g. {"fem": {"formulation", "dofs",
  // "solver", "factor_ms"}} for model "fem"; `palplab probe` merges it into its output.
  std::string model_info;
};

struct SceneImpl;

class Scene {
 public:
  // Scenes are made by engine::make_scene (SceneImpl is private to the engine).
  explicit Scene(std::unique_ptr<SceneImpl> impl);
  Scene(Scene&&) noexcept;
  Scene& operator=(Scene&&) noexcept;
  ~Scene();

  // One haptic step (dt() seconds of simulated time) with the HCP at `device_position` (m).
  Rendered step(const Eigen::Vector3d& device_position);
  // The sample of the last step (t, device position, force, contact node).
  Sample last_sample() const;
  // Back to the state right after construction (rest shape, t = 0, no contact). Cheap: no mesh
  // generation, no precomputation.
  void reset();

  double dt() const;  // s, haptic step
  double time() const;
  const SceneGeometry& geometry() const;
  const std::string& prototype() const;  // "A", "B", "C", "C1", "C2", ...
  const char* model_kind() const;        // "penalty", "ring", "mass_spring", ...
  // Multi-tool scenes (model "needle": "finger" palpates the skin, "needle" inserts along the
  // stylus axis, a unit vector pointing from the handle to the tip, in the organ's frame). Takes
  // effect from the next step; an event tool_changed is logged when the tool changes. A real
  // device calls it whenever its stylus turns. InputError for a tool the model does not have.
  void set_tool(const std::string& tool, const Eigen::Vector3d& stylus_axis);
  // Stepped in real time (engine::run_realtime sets it for its run) or in lock-step (default):
  // work a model does beside the haptic loop (C's exterior solve) is adopted when ready instead
  // of after a fixed number of steps; faster, but not reproducible run to run.
  void set_realtime(bool realtime);
  // Rendered::visible_volume is computed (at the display's frame rate) from the next step on;
  // off by default: it reads the whole drawn surface, which some models bring up to date for it.
  void set_visible_volume(bool on);
  std::string tool() const;           // "probe" for single-tool models
  const SceneConfig& config() const;  // what the scene was built from (copy it for a variant)
  Thresholds thresholds(int region) const;
  SceneStats stats() const;
  // Current (deformed) positions of the simulated surface nodes, #V(now) by 3 (m), and faces of
  // the current (possibly refined) surface — for a renderer. Not part of the perception contract.
  void current_surface(mesh::Positions& V, mesh::Faces& F) const;

 private:
  std::unique_ptr<SceneImpl> impl_;
};

}  // namespace palplab::engine
