#pragma once
// The virtual trainee and instructor (docs/PARTICIPANTS.md): a perception–memory–motor
// model whose ONLY inputs are what the simulator renders in each haptic step (force on the hand,
// contact and the touched region, visible deformation, audio cue) plus the instructor's spoken
// call. Nothing here knows a prototype's id or name; group differences can arise only from what
// the simulator renders.
//
// Perception: a judgement of force uses a per-press multiplicative error (Weber law, SD =
// weber_fraction * F) on the haptic channel and, when the touched region visibly deforms, a
// visual estimate  F_v = k_hat * d_perceived  (k_hat: the trainee's learned ratio of felt force
// to seen deformation). Both are combined by maximum likelihood (weights ∝ 1/variance).
// Memory: a Gaussian belief about the target force (mean, variance), updated like a Kalman
// filter whenever a cue marks "target reached" (sound onset, instructor's call), forgotten by a
// power law over the retention interval; a belief about the feature's position, likewise.
// Motor: each press aims at the believed target times (1 + motor noise), SD ∝ force.
//
// Units: N, m, s. Positions in the organ's frame.
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "protocols/participants/params.hpp"
#include "protocols/rng.hpp"

namespace palplab::engine {
struct Rendered;
}

namespace palplab::json {
class Checker;
}

namespace palplab::protocols::participants {

// What one haptic step renders, as a participant perceives it (a copy of engine::Rendered's
// perceivable fields; the runner fills it).
struct Percept {
  double t = 0.0;                                   // s, end of the step
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  // N, on the hand
  bool contact = false;
  int contact_region = -1;
  double visible_deformation = 0.0;  // m, 0 when nothing is drawn
  double visible_volume = 0.0;       // m^3, pushed-in volume of the drawn surface (when computed)
  bool audio = false;
  // Needle scenes with transparency: the tip's distance to the target (m) and the tissue at the
  // tip as drawn; -1 when not shown.
  double visible_tip_to_target = -1.0;
  int visible_tip_tissue = -1;
};

// The percept of one rendered step (every perceivable field of engine::Rendered); the one copy
// used by the palpation and the needle sessions.
Percept percept_of(const engine::Rendered& r);

// The rest surface the trainee explores (what a person sees of the organ before touching it).
struct SurfaceView {
  const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>* V = nullptr;  // #V by 3 (m)
  const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>* N = nullptr;  // #V by 3 normals
  const std::vector<int>* vertex_region = nullptr;                               // #V
  int feature_region = -1;  // region index of the feature to find
  Eigen::Vector3d feature_centroid = Eigen::Vector3d::Zero();  // anatomy known from the briefing
  Eigen::Vector3d start_position = Eigen::Vector3d::Zero();
};

// Which rendered channels a role may use in a session (experiment 1: the trainee feels only the
// force, the instructor sees and hears the cues).
struct Channels {
  bool haptic = true, visual = true, audio = true;
  bool call = false;  // an instructor may call "release" (the trainee listens for it)
};

// ---- perception (free functions, unit-tested)
struct Estimate {
  double value = 0.0;     // N
  double variance = 0.0;  // N^2
};
// Maximum-likelihood combination of independent Gaussian estimates; `weights` (optional) gets
// the weight of each input (∝ 1/variance, summing to 1).
Estimate mle_combine(const std::vector<Estimate>& in, std::vector<double>* weights = nullptr);

// Power-law retention: share of what was learned that is kept after `dt` seconds.
double retention(double dt, const TraineeParams& p);

// What a demonstration press up to the target force on a simulator renders (the briefing shows
// one on the simulator the trainee first trains on; the instructor makes one before coaching).
struct Demonstration {
  double deformation = 0.0;  // m, visible deformation when the target force is reached (mean)
  bool sound = false;        // the audio cue came on the way to the target force
  std::vector<double> seen;  // m, that deformation in each press that reached the target
  double volume = 0.0;       // m^3, the visible volume at the target (mean; when computed)
  std::vector<double> seen_volume;  // m^3, in each press that reached the target (beside seen)
};

// The area that turns a pushed-in volume into a depth (a fingertip's, 1 cm^2): only the scale
// of the judged deformation, which every judgement shares.
inline constexpr double kSeenVolumeArea = 1e-4;  // m^2
// The deformation a trainee judges from the indentation d (m) and the pushed-in volume v (m^3)
// with visual_volume_weight w: d^(1-w) (v / kSeenVolumeArea)^w; exactly d when w = 0.
double seen_deformation(double d, double v, double w);

// ---- the trainee
struct TraineeState {
  bool initialised = false;
  double target_mean = 0.0, target_var = 0.0;  // belief about the target force (N, N^2)
  double prior_mean = 0.0, prior_var = 0.0;    // what the briefing left (forgetting decays to it)
  Eigen::Vector3d place = Eigen::Vector3d::Zero();  // believed feature position (m)
  double place_sd = 0.0;                            // m
  double k_hat = 0.0;  // N/m learned felt-force / seen-deformation ratio (0 = none yet)
  int k_count = 0;
  double k_felt_sum = 0.0, k_seen_sum = 0.0;  // N, m: sums over calibrating presses
  int feedback_count = 0;                     // target markers experienced so far
  double last_session_end = 0.0;              // s of study time
  // What the briefing's demonstration press showed (on the first session's simulator).
  bool demo_sound = false;        // a sound came on the way to the target force
  double demo_d = 0.0;            // m, visible deformation at the target as remembered (0 = none)
  double reliance = 0.0;          // 0..1, reliance on a binary marker (guidance hypothesis)
  int finds = 0;                  // sessions in which the feature was found (practice)
  double speed_factor = 1.0;      // individual speed (>1 faster), drawn at the briefing
  double overshoot_factor = 1.0;  // individual factor on marker_wait_overshoot, drawn at briefing
  double k_log_sum = 0.0, k_log_sq = 0.0;  // Σ log(felt/seen), Σ log² over calibrating presses
  // Landmark judgements practised so far; one confirmed by seeing the touched part deform
  // counts 1 + visual_recognition_gain (orienting practice, see draw_landmark_time).
  double landmark_practice = 0.0;
  // Needle task: belief about the target's depth below the skin (m, m^2; 0 = not briefed yet).
  double depth_mean = 0.0, depth_var = 0.0;
  nlohmann::json to_json() const;
  // The state as to_json wrote it (keys added later may be missing: their defaults). Anything
  // else (a state edited in the database: a missing key, a wrong type, a non-finite or
  // impossible value) is a problem recorded on `c` (the one JSON validator, common/json_check) at
  // its JSON path; the caller decides how to say them.
  static TraineeState from_json(const nlohmann::json& j, palplab::json::Checker& c);
  // The same, throwing the problems as one InputError ("trainee state: $.key: ...").
  static TraineeState from_json(const nlohmann::json& j);
};

class Trainee {
 public:
  // `briefed_target`: the MPF of the feature, told in the briefing (N).
  Trainee(const TraineeParams& params, TraineeState state);

  // Session start: applies forgetting over the interval since the last session, then plans the
  // search. `study_time`: s of study time at the session start; `seed`: the session's seed.
  void begin_session(const SurfaceView& view, double briefed_target, double study_time,
                     double duration, std::uint64_t participant_seed, std::uint64_t seed,
                     Channels channels);
  // The device position for the next step, given what the previous step rendered.
  Eigen::Vector3d command(double t);
  // The briefing's demonstration (used when the state is not yet initialised; call before
  // begin_session).
  void set_demonstration(const Demonstration& d) { demo_ = d; }
  // Perceives one step's output; `call`: an instructor said "release" in this step.
  void perceive(const Percept& p, bool call);
  // Session end (study time at the end).
  void end_session(double study_time);

  const TraineeState& state() const { return s_; }
  // For tests and logs: the intended force of the current/last press (N) and presses made.
  double intended_force() const { return intended_; }
  int presses() const { return presses_; }
  bool identified() const { return identified_; }

 private:
  enum class Mode { travel, descend, dwell, press, hold, release, rest };
  void choose_search_target();
  // Orienting: the landmarks on the route to the believed feature position (plan_route, at the
  // session start), touched one after the other before the search proper (next_probe).
  void plan_route();
  void next_probe();
  int nearest_node(const Eigen::Vector3d& q) const;
  void start_travel(const Eigen::Vector3d& to, Mode next);
  double perceived_force(const Percept& p) const;
  double perceived_variance(const Percept& p) const;
  void learn_target(double observed, double variance, double gain_scale = 1.0);
  // An expected "target reached" marker did not come at felt force `felt` (N): the target is
  // above it (a censored observation; moment-matched truncation of the belief).
  // trust: prior probability that the awaited cue works (the reliance for a sound or call; 1 for
  // the picture, which is always in view).
  void learn_lower_bound(double felt, double trust);
  double draw_recognition_time();
  double draw_landmark_time();
  // At the end of a landmark judgement: whether this landmark felt softer or harder than the
  // session's previous one by more than the stiffness JND (and remember its stiffness).
  bool landmark_felt_distinct();
  void start_press();
  void begin_release(double t);
  // Where the next press goes: the feature's surface node nearest a point aimed at the place
  // where the target press was demonstrated (the feature's centre), with a reach's scatter;
  // the hand waits `clearance` above it along its outward normal (hover_).
  void aim_press(double clearance);

  TraineeParams p_;
  TraineeState s_;
  Rng rng_{0};
  Rng aim_rng_{0};  // the press aims (its own stream: the other draws are as before)
  SurfaceView view_;
  Channels ch_;
  double briefed_ = 0.0;
  Mode mode_ = Mode::travel;
  Eigen::Vector3d pos_ = Eigen::Vector3d::Zero(), goal_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d press_dir_ = Eigen::Vector3d::Zero();  // unit, into the surface
  Mode after_travel_ = Mode::descend;
  int target_node_ = -1;
  int press_node_ = -1;  // node the current/next press aims at (-1: press where the hand is)
  Eigen::Vector3d hover_ = Eigen::Vector3d::Zero();  // where the hand waits before a press
  int search_k_ = 0;
  std::vector<int> probed_;    // surface nodes probed this session
  std::vector<int> route_;     // landmark nodes of this session's orienting route
  std::size_t route_i_ = 0;    // next landmark to touch
  bool orienting_ = false;     // the current touch is a landmark, not a search probe
  double travel_speed_ = 0.0;  // m/s of the current travel (before the speed factor)
  double travel_len_ = 0.0;    // m, straight-line length of the current travel
  bool identified_ = false;
  double dwell_start_ = -1.0, mode_start_ = 0.0, release_at_ = -1.0;
  double intended_ = 0.0, eps_h_ = 0.0, eps_v_ = 0.0, rt_scale_ = 1.0;
  // Standardised motor and haptic errors of the last press (AR(1) across a session's presses).
  double z_motor_ = 0.0, z_haptic_ = 0.0;
  bool audio_seen_ = false, call_heard_ = false;
  // A trainee who knows a cue marks the target presses until it comes (up to a limit); the
  // first press of a session tries, and the expectation stays while the cue keeps coming.
  bool expect_marker_ = false, marker_in_session_ = false;
  int presses_ = 0;
  Percept last_;
  std::optional<Demonstration> demo_;
  int misses_ = 0;  // consecutive presses of this session whose expected marker did not come
  bool marker_this_press_ = false, visual_marker_ = false, dwell_saw_d_ = false;
  // This press stopped at its bound while aiming at the remembered picture (not reached).
  bool visual_bound_stop_ = false;
  double rec_time_ = 0.0;
  // Felt compliance of a landmark: where the hand first touched in this dwell, and the stiffness
  // (felt force / hand travel since that touch) of this session's previous landmark (< 0: none).
  Eigen::Vector3d touch_pos_ = Eigen::Vector3d::Zero();
  double prev_landmark_k_ = -1.0;
  double peak_seen_d_ = 0.0, peak_felt_ = 0.0;
  double press_d0_ = -1.0;  // m, seen deformation when this press first touched (-1: not yet)
  double t_prev_ = 0.0;
  // Release: where the contact ended, and whether something resisted the lift.
  static constexpr double kReleaseClearance = 0.002;  // m lifted after the contact ends
  Eigen::Vector3d lift_off_ = Eigen::Vector3d::Zero();
  bool lifted_off_ = false, release_blocked_ = false;
};

// ---- the instructor (experiment 1): watches the rendered cues and calls "release".
class Instructor {
 public:
  Instructor(const InstructorParams& params, std::uint64_t seed);
  // Calibration: the deformation the instructor expects at the target, from an own press on the
  // same simulator (the runner performs it on a scene and resets the scene afterwards). 0 = the
  // simulator shows no deformation, so only the sound can be used.
  void set_target_deformation(double d) { target_d_ = d; }
  // True in the step in which the call reaches the trainee's ears (after the instructor's
  // reaction time). `ch`: what the instructor may perceive.
  bool observe(const Percept& p, Channels ch);
  void reset_press();  // the trainee released: wait for the next press

 private:
  InstructorParams p_;
  Rng rng_;
  double target_d_ = 0.0, eps_ = 0.0, rt_scale_ = 1.0;
  double call_at_ = -1.0;
  double d0_ = -1.0;  // m, seen deformation when the current press first touched (-1: not yet)
  bool called_ = false, prev_audio_ = false;
};

}  // namespace palplab::protocols::participants
