#include "protocols/runner.hpp"

#include "common/escape.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <regex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "common/input_error.hpp"
#include "common/json_check.hpp"
#include "common/seed.hpp"
#include "engine/haptics/clock.hpp"
#include "engine/haptics/devices/tool_switch.hpp"
#include "engine/haptics/press.hpp"
#include "engine/scene.hpp"
#include "palplab/version.hpp"
#include "protocols/input_pins.hpp"
#include "protocols/measures.hpp"
#include "protocols/needle_session.hpp"
#include "protocols/participants/model.hpp"
#include "protocols/participants/params.hpp"
#include "prototypes/factory.hpp"
#include "results/sha256.hpp"
#include "results/store.hpp"

namespace fs = std::filesystem;

namespace palplab::protocols {

namespace {

using Clock = std::chrono::steady_clock;
namespace pm = participants;

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

ForceLimits limits_for(const Study& s, const std::string& region) {
  if (auto it = s.task.thresholds.find(region); it != s.task.thresholds.end()) return it->second;
  if (auto it = s.task.thresholds.find("*"); it != s.task.thresholds.end()) return it->second;
  return {};
}

// The structure the report reads from the database (results/schema.sql: study_groups, phases,
// thresholds). Thresholds are task-wide in study format 1, so every phase gets the same table.
results::StudyStructure study_structure(const Study& s) {
  results::StudyStructure out;
  out.has_structure = true;
  for (const auto& g : s.groups) out.groups.push_back({g.id, g.prototype});
  for (const auto& ph : s.phases) {
    results::PhaseRecord r;
    r.phase = ph.id;
    r.kind = ph.kind.empty() ? "other" : ph.kind;
    r.sessions = ph.sessions;
    r.session_duration = ph.session_duration;
    r.haptic = ph.cues.haptic;
    r.visual_deformation = ph.cues.visual_deformation;
    r.audio = ph.cues.audio;
    r.transparency = ph.cues.transparency;
    r.instructed = ph.instructed;
    r.feature = s.task.feature;
    for (const auto& [region, l] : s.task.thresholds)
      r.thresholds.push_back({region, l.st, l.mpf, l.sft});
    out.phases.push_back(r);
  }
  return out;
}

// One demonstration press on `node` of this simulator: a slow deliberate press until the force,
// judged with relative error `eps`, reaches the MPF; what it rendered on the way (the visible
// deformation at the target, 0 when none is drawn; whether the sound came). The scene is reset
// afterwards.
pm::Demonstration demonstrate_at(engine::Scene& scene, int node, double mpf, double eps) {
  engine::PressSpec spec = engine::press_at(scene.geometry(), node, mpf, 0.0, 0.0);
  spec.approach_speed = 0.004;  // m/s, a slow deliberate press
  // 1 cm outside; its first step is already one step in (as the studies' reference results were
  // made: the demonstration reaches the MPF at the same device positions).
  spec.start_offset = 0.01 - spec.approach_speed * scene.dt();  // m
  spec.force_error = eps;
  spec.stop_at_target = true;
  spec.max_depth = 1.0;  // never given up for depth: only the 20 s below end it
  spec.max_approach_time = 20.0;
  engine::PressDevice press(spec);
  pm::Demonstration d;
  double deformation = 0.0, volume = 0.0;
  engine::run_lockstep(scene, press, {.duration = 20.0, .frame_period = 0.0},
                       [&](const engine::Rendered& r, const engine::Sample&) {
                         d.sound = d.sound || r.audio;
                         deformation = r.visible_deformation;
                         volume = r.visible_volume;
                       });
  if (press.force_reached()) d.deformation = deformation, d.volume = volume;
  scene.reset();
  return d;
}

// The surface nodes of the feature a demonstration presses: the kDemonstrationPresses nodes of
// its region nearest the region's centroid (the same neighbourhood the trainees' search, drawn
// around the believed centroid, ends up pressing). Geometry only: nothing depends on which
// prototype this is.
constexpr int kDemonstrationPresses = 5;
std::vector<int> demonstration_nodes(const engine::SceneGeometry& g, const std::string& feature) {
  const int r = g.region_index(feature);
  const Eigen::Vector3d c = g.region_centroid(feature);
  std::vector<std::pair<double, int>> by_distance;
  for (int i = 0; i < static_cast<int>(g.vertex_region.size()); ++i)
    if (g.vertex_region[i] == r)
      by_distance.push_back({(g.V.row(i).transpose() - c).squaredNorm(), i});
  const std::size_t k = std::min<std::size_t>(kDemonstrationPresses, by_distance.size());
  std::partial_sort(by_distance.begin(), by_distance.begin() + k, by_distance.end());
  std::vector<int> nodes;
  for (std::size_t i = 0; i < k; ++i) nodes.push_back(by_distance[i].second);
  return nodes;
}

// The demonstration of the target press on the feature of this simulator: the target press
// shown at each demonstration node (a few presses around the feature, not one: a simulated
// organ's stiffness varies from place to place — on prototype C the node nearest the ovary's
// centroid, formerly the only one shown, takes 600 N/m, the places the trainees press 220–440
// N/m — so one press at one arbitrary point shows a deformation at the target that the
// trainee's own presses elsewhere do not reproduce). What is remembered is the mean picture at
// the target (ensemble averaging: observers keep the mean of a set of seen sizes, Ariely 2001)
// and whether a sound came in any press. Used for the instructor's own calibration (eps from
// the instructor's Weber fraction, one hand bias for all presses) and for the briefing's
// demonstration to the trainee (eps 0: the trainee watches an exact demonstration).
pm::Demonstration demonstrate(engine::Scene& scene, const std::string& feature, double mpf,
                              double eps) {
  pm::Demonstration d;
  double sum = 0.0, sum_volume = 0.0;
  int reached = 0;
  for (int node : demonstration_nodes(scene.geometry(), feature)) {
    const pm::Demonstration one = demonstrate_at(scene, node, mpf, eps);
    d.sound = d.sound || one.sound;
    if (one.deformation > 0) {
      sum += one.deformation, sum_volume += one.volume, ++reached;
      d.seen.push_back(one.deformation);
      d.seen_volume.push_back(one.volume);
    }
  }
  if (reached > 0) d.deformation = sum / reached, d.volume = sum_volume / reached;
  return d;
}

// The scene of one session: the session's prototype with the phase's cue switches and the
// study's thresholds.
engine::Scene session_scene(const Study& study, const SessionSpec& spec) {
  engine::SceneOverrides ov;
  ov.haptic = spec.cues.haptic;
  ov.visual_deformation = spec.cues.visual_deformation;
  ov.audio = spec.cues.audio;
  ov.transparency = spec.cues.transparency;
  for (const auto& [region, l] : study.task.thresholds) {
    engine::Thresholds t;
    t.st = l.st;
    t.mpf = l.mpf;
    t.sft = l.sft;
    ov.thresholds[region] = t;
  }
  return prototypes::build_scene(spec.prototype_file, ov);
}

// The measures of a session from its log, exactly as `run` computes them for every trainee.
std::vector<results::MeasureRecord> session_measures(const Study& study,
                                                     const engine::SceneGeometry& g,
                                                     const results::SampleSeries& samples,
                                                     const std::vector<results::EventRecord>& ev) {
  if (study.task.kind == "needle_insertion") return compute_needle_measures(ev);
  MeasureInputs mi;
  mi.samples = &samples;
  mi.events = &ev;
  mi.vertex_region = &g.vertex_region;
  mi.feature_region = g.region_index(study.task.feature);
  mi.mpf = limits_for(study, study.task.feature).mpf;
  mi.accuracy_tolerance = study.task.accuracy_tolerance;
  mi.identify_dwell = study.task.identify_dwell;
  mi.palpation_onset = study.task.palpation_onset;
  return compute_measures(mi);
}

// One haptic step of a session's log (virtual and human sessions alike): the device position
// given to the step, the force on the hand, the contact node, and the step's events with their
// region names.
void log_step(const engine::Rendered& r, const engine::Sample& smp,
              const std::vector<std::string>& region_names, results::SampleSeries& samples,
              std::vector<results::EventRecord>& events) {
  samples.x.insert(samples.x.end(), {smp.x.x(), smp.x.y(), smp.x.z()});
  samples.F.insert(samples.F.end(), {smp.F.x(), smp.F.y(), smp.F.z()});
  samples.node.push_back(smp.contact_node);
  for (const auto& e : r.events)
    events.push_back({e.t, engine::to_string(e.kind), e.value,
                      e.region >= 0 && e.region < static_cast<int>(region_names.size())
                          ? region_names[e.region]
                          : std::string()});
}

// A virtual trainee (and, in an instructed session, the instructor watching) as the haptic
// device of the one lock-step loop: read() is the trainee's command for the end of the step,
// write() what both perceive of the step. The command time is counted here as step * dt, the
// scene's own clock (Scene: t = step index * dt), not t + dt of the read time, which rounds
// differently.
class VirtualParticipant : public engine::Device {
 public:
  VirtualParticipant(pm::Trainee& trainee, pm::Instructor* instructor, pm::Channels instructor_ch,
                     double dt)
      : trainee_(trainee), instructor_(instructor), instructor_ch_(instructor_ch), dt_(dt) {}
  engine::DeviceInput read(double) override {
    engine::DeviceInput in;
    in.position = trainee_.command(static_cast<double>(++step_) * dt_);
    return in;
  }
  void write(const engine::Rendered& r) override {
    const pm::Percept p = pm::percept_of(r);
    bool call = false;
    if (instructor_) {
      call = instructor_->observe(p, instructor_ch_);
      if (prev_contact_ && !r.contact) instructor_->reset_press();
    }
    prev_contact_ = r.contact;
    trainee_.perceive(p, call);
  }

 private:
  pm::Trainee& trainee_;
  pm::Instructor* instructor_;
  pm::Channels instructor_ch_;
  double dt_;
  long step_ = 0;
  bool prev_contact_ = false;
};

struct SessionOutcome {
  results::SessionData data;
  pm::TraineeState state_after;
  // The device track when the session records its own (needle sessions: the tool and the stylus
  // axis, which the samples lack); empty otherwise (the track is the samples' positions).
  engine::Trace track;
};

// The model parameters of a study, converted from its (validated) JSON once per run.
struct ModelParams {
  pm::TraineeParams trainee;
  pm::InstructorParams instructor;
  explicit ModelParams(const Study& s)
      : trainee(pm::trainee_params(s.participant_parameters, s.file)),
        instructor(pm::instructor_params(
            s.instructor ? s.instructor->parameters : nlohmann::json::object(), s.file)) {}
};

// The session record around a session's log (both task kinds); the trainee's state goes through
// JSON exactly as a resumed run reads it back.
SessionOutcome finish_session(const ParticipantPlan& pp, const SessionSpec& spec,
                              results::SessionData out, long steps, double dt, double wall,
                              const engine::TimingSummary& loop, double loop_unit_s,
                              const nlohmann::json& state) {
  results::SessionRecord& rec = out.session;
  rec.participant = pp.id;
  rec.ordinal = spec.ordinal;
  rec.phase = spec.phase_id;
  rec.phase_index = spec.index;
  rec.prototype = spec.prototype;
  rec.instructor = spec.instructor;
  rec.study_offset = spec.offset;
  rec.day = spec.day;
  rec.duration = steps * dt;
  rec.steps = steps;
  rec.wall_duration = wall;
  if (loop.count > 0) {
    rec.loop_median = loop.median * loop_unit_s;
    rec.loop_p99 = loop.p99 * loop_unit_s;
  }
  rec.seed = spec.seed;
  rec.state_after = state.dump();
  SessionOutcome o;
  o.state_after = pm::TraineeState::from_json(nlohmann::json::parse(rec.state_after));
  o.data = std::move(out);
  return o;
}

SessionOutcome run_session(const Study& study, const ModelParams& mp, const ParticipantPlan& pp,
                           const SessionSpec& spec, const pm::TraineeState& state_before,
                           bool keep_samples,
                           const std::map<std::string, std::string>& prototype_sha,
                           bool record_track = false) {
  // The scene is built from the file; it must still be the file recorded when the run started,
  // or the database would mix two simulators under one name.
  if (auto it = prototype_sha.find(spec.prototype);
      it != prototype_sha.end() && prototype_sha256(spec.prototype_file) != it->second)
    throw InputError(
        "prototype file or its mesh.file changed since the run started (SHA-256 differs from "
        "the one stored in the database); restore it or start a new run",
        spec.prototype_file);
  engine::Scene scene = session_scene(study, spec);
  if (study.task.kind == "needle_insertion") {
    NeedleSessionRun nr = run_needle_session(study, mp.trainee, pp.seed, spec, state_before, scene,
                                             keep_samples, record_track);
    nr.data.session.transparency = scene.config().cues.transparency;
    SessionOutcome o = finish_session(pp, spec, std::move(nr.data), nr.steps, scene.dt(), nr.wall,
                                      engine::summarize_times({nr.loop.begin(), nr.loop.end()}),
                                      1.0, nr.state_after.to_json());
    o.track = std::move(nr.track);
    return o;
  }
  // A trainee who judges the deformation by the whole picture needs the picture's volume.
  scene.set_visible_volume(mp.trainee.visual_volume_weight > 0.0);
  const engine::SceneGeometry& g = scene.geometry();
  const int feature = g.region_index(study.task.feature);
  if (feature < 0)
    throw InputError(
        "prototype \"" + spec.prototype + "\" has no region \"" + study.task.feature + "\"",
        spec.prototype_file);
  const ForceLimits lim = limits_for(study, study.task.feature);

  pm::SurfaceView view;
  view.V = &g.V;
  view.N = &g.N;
  view.vertex_region = &g.vertex_region;
  view.feature_region = feature;
  view.feature_centroid = g.region_centroid(study.task.feature);
  view.start_position = g.start_position;

  const bool instructed = !spec.instructor.empty();
  // Experiment 1: the trainee feels only the force; the instructor sees and hears the cues.
  pm::Channels trainee_ch;
  if (instructed) trainee_ch = pm::Channels{true, false, false, true};
  const pm::Channels instructor_ch{false, true, true, false};

  pm::Trainee trainee(mp.trainee, state_before);
  std::optional<pm::Instructor> instructor;
  if (instructed) {
    const std::uint64_t iseed =
        derive_seed(spec.seed, label_hash("instructor"), label_hash(spec.instructor));
    instructor.emplace(mp.instructor, iseed);
    // The instructor calibrates with the instructor's own Weber fraction (an expert's hand).
    Rng rng(derive_seed(iseed, "instructor-calibration"));
    const double eps = mp.instructor.weber_fraction * rng.normal();
    instructor->set_target_deformation(
        demonstrate(scene, study.task.feature, lim.mpf, eps).deformation);
  }
  // The briefing (before the first session) demonstrates the target press on this simulator.
  if (!state_before.initialised)
    trainee.set_demonstration(demonstrate(scene, study.task.feature, lim.mpf, 0.0));
  trainee.begin_session(view, lim.mpf, spec.offset, spec.duration, pp.seed, spec.seed, trainee_ch);

  const double dt = scene.dt();
  const long steps = std::lround(spec.duration / dt);
  results::SessionData out;
  results::SampleSeries samples;
  samples.t0 = 0.0;
  samples.dt = dt;
  samples.x.reserve(3 * steps);
  samples.F.reserve(3 * steps);
  samples.node.reserve(steps);
  // Step times for the loop median / p99: every kTimedEvery-th step (reading the clock twice
  // per step cost 12 % of an exp2 run; a systematic 1-in-8 sample estimates both quantiles).
  constexpr int kTimedEvery = 8;
  std::vector<double> loop_us;
  loop_us.reserve(steps / kTimedEvery + 1);
  VirtualParticipant hand(trainee, instructor ? &*instructor : nullptr, instructor_ch, dt);
  engine::TimedDevice timed(hand, loop_us, kTimedEvery);
  const auto wall0 = Clock::now();
  engine::run_lockstep(scene, timed, {.duration = spec.duration, .frame_period = 0.0},
                       [&](const engine::Rendered& r, const engine::Sample& smp) {
                         log_step(r, smp, g.region_names, samples, out.events);
                       });
  const double wall = std::chrono::duration<double>(Clock::now() - wall0).count();
  trainee.end_session(spec.offset + spec.duration);

  out.measures = session_measures(study, g, samples, out.events);
  if (keep_samples) out.samples = std::move(samples);
  out.session.transparency = scene.config().cues.transparency;
  return finish_session(pp, spec, std::move(out), steps, dt, wall,
                        engine::summarize_times(std::move(loop_us)), 1e-6,
                        trainee.state().to_json());
}

// The `--samples` setting of a run being continued: meta "samples" (a run started before it was
// stored: what its first session holds); an explicit other setting is refused (a database holds
// the samples of every session or of none).
bool run_samples_setting(results::Store& store, const std::vector<results::SessionRecord>& stored,
                         bool samples, bool samples_explicit, const std::string& db) {
  std::optional<std::string> m = store.read_meta("samples");
  if (!m) {
    m = stored.empty()                                           ? (samples ? "full" : "none")
        : store.read_samples(stored.front().session).size() == 0 ? "none"
                                                                 : "full";
    store.write_meta("samples", *m);
  }
  const bool was = *m == "full";
  if (samples_explicit && was != samples)
    throw InputError("the run started with --samples " + *m + ", this one asks for --samples " +
                         (samples ? "full" : "none") +
                         "; a database holds the samples of every session or of none (drop "
                         "--samples to keep the run's setting)",
                     db);
  return was;
}

// Whether an existing database without a study record is an interrupted start (created, then
// stopped before write_start, one transaction, was written): start the run in it. Rows of a run
// without a study record are a damaged database instead (exit 2, never started over); `cannot`
// ends its message ("resume it (--force replaces it)").
bool interrupted_start(results::Store& store, const std::string& db, const std::string& cannot) {
  if (store.has_study()) return false;
  if (const long long n = store.count_run_rows())
    throw InputError("damaged database: it has no study record but " + std::to_string(n) +
                         " rows of a run (sessions, participants, ...); palplab cannot " + cannot,
                     db);
  return true;
}

// "the database holds a run of another study file: ...", naming both (the same id: an edit),
// then `needs`.
std::string another_study(const results::StudyRecord& rec, const Study& study,
                          const std::string& sha, const std::string& needs) {
  const std::string theirs = nlohmann::json(rec.study_id).dump();
  const std::string ours = nlohmann::json(study.id).dump();
  return "the database holds a run of another study file: study " + theirs + " (SHA-256 " +
         rec.sha256.substr(0, 12) + "…), this file is " +
         (theirs == ours ? "an edited version of it" : "study " + ours) + " (SHA-256 " +
         sha.substr(0, 12) + "…); " + needs;
}

// The planned participants with a session not complete in the database, in plan order.
std::vector<std::string> participants_left(const Plan& plan, const results::Store& store) {
  std::set<std::pair<std::string, int>> done;
  for (const auto& s : store.read_attempts())
    if (s.status == "complete") done.insert({s.participant, s.ordinal});
  std::vector<std::string> left;
  for (const auto& p : plan.participants)
    for (const auto& ss : p.sessions)
      if (!done.count({p.id, ss.ordinal})) {
        left.push_back(p.id);
        break;
      }
  return left;
}

// A new database: the study, its prototypes (with their SHA-256), participants and structure,
// and meta "samples" (full or none), in one transaction.
void write_new_study(const Study& study, const Plan& plan, const std::string& sha,
                     results::Store& store, std::map<std::string, std::string>& prototype_sha,
                     bool samples, const std::string& started_at = results::utc_now()) {
  results::StudyRecord rec;
  rec.study_id = study.id;
  rec.title = study.title;
  rec.json = study.json_text;
  rec.sha256 = sha;
  rec.palplab_version = kVersion;
  rec.git_commit = kGitCommit;
  rec.seed = study.seed;
  rec.started_at = started_at;
  std::vector<results::PrototypeRecord> protos;
  for (const auto& [id, path] : study.prototype_files) {
    std::string text = slurp(path);
    protos.push_back({id, path, prototype_sha256(path), text});
    prototype_sha[id] = protos.back().sha256;
  }
  std::vector<results::ParticipantRecord> parts;
  for (const auto& p : plan.participants) parts.push_back({p.id, p.group, p.number, p.seed});
  store.write_start(rec, protos, parts, study_structure(study),
                    {{"samples", samples ? "full" : "none"}});
}

}  // namespace

std::vector<results::SessionData> simulate_participant(const Study& study,
                                                       const ParticipantPlan& pp,
                                                       bool keep_samples) {
  const ModelParams mp(study);
  std::vector<results::SessionData> out;
  pm::TraineeState state;
  for (const auto& spec : pp.sessions) {
    SessionOutcome o = run_session(study, mp, pp, spec, state, keep_samples, {});
    state = o.state_after;
    out.push_back(std::move(o.data));
  }
  return out;
}

RunSummary run_study(const Study& study, const Plan& plan, const RunOptions& opt) {
  const auto t0 = Clock::now();
  const std::string sha = results::sha256_hex(study.json_text);
  const bool exists = fs::exists(opt.db);
  // A mistyped path with --resume would otherwise start a new run in a new file.
  if (!exists && opt.resume)
    throw InputError(
        "nothing to resume: the database does not exist (check the path; without --resume, "
        "`run` creates a new database)",
        opt.db);
  if (exists && fs::is_directory(opt.db) && !opt.force)
    throw InputError("is a directory (expected a results database file)", opt.db);
  if (exists && !opt.resume && !opt.force)
    throw InputError(
        "the database already exists; use --resume to continue it or --force to "
        "replace it",
        opt.db);
  // A run interrupted while it created the database leaves an empty file: nothing to resume,
  // nothing to lose; the run starts in its place.
  bool fresh = !exists;
  if (exists && opt.resume && results::Store::remove_empty_leftover(opt.db)) {
    if (opt.notice)
      opt.notice(opt.db + " holds no run yet (its start was interrupted): starting the run");
    fresh = true;
  }
  if (exists && opt.force && !opt.resume) {
    std::string what;
    if (opt.notice && fs::is_regular_file(opt.db)) {
      try {  // what is lost (remove_existing refuses anything not palplab's)
        results::Store old = results::Store::open(opt.db);
        const results::StudyRecord rec = old.read_study();
        const std::size_t n = old.read_sessions().size();
        what = "a run of study " + nlohmann::json(rec.study_id).dump() + ", " + std::to_string(n) +
               " session" + (n == 1 ? "" : "s") + ", " +
               (rec.finished_at.empty() ? "INCOMPLETE" : "complete");
      } catch (const std::exception&) {
      }
    }
    results::Store::remove_existing(opt.db);  // a palplab database only, never any file
    // Said once it is done: "replacing" was printed before a database in use was refused.
    if (!what.empty()) opt.notice("replaced " + opt.db + " (--force): it held " + what);
  }
  results::Store store =
      fs::exists(opt.db) ? results::Store::open(opt.db, true) : results::Store::create(opt.db);
  if (!fresh && opt.resume && interrupted_start(store, opt.db, "resume it (--force replaces it)")) {
    if (opt.notice)
      opt.notice(opt.db + " holds no run yet (its start was interrupted): starting the run");
    fresh = true;
  }
  std::map<std::string, std::map<int, std::string>> done;  // participant -> ordinal -> state
  std::map<std::string, std::string> prototype_sha;        // id -> SHA-256 at run start
  std::set<std::string> human;  // participants run with people (`run --human`): not simulated
  std::vector<results::SessionRecord> stored;  // complete sessions found on resume
  bool keep_samples = opt.samples;
  if (!fresh && opt.resume) {
    results::StudyRecord rec = store.read_study();
    if (rec.sha256 != sha)
      throw InputError(another_study(rec, study, sha,
                                     "resume needs the identical study file (to run this one: "
                                     "another --db, or --force to replace that run)"),
                       opt.db);
    stored = store.read_sessions();
    keep_samples = run_samples_setting(store, stored, opt.samples, opt.samples_explicit, opt.db);
    auto parts = store.read_participants();
    bool same = parts.size() == plan.participants.size();
    for (std::size_t i = 0; same && i < parts.size(); ++i)
      same = parts[i].participant == plan.participants[i].id &&
             parts[i].group == plan.participants[i].group;
    if (!same) throw InputError("the database's participants differ from the plan", opt.db);
    for (const auto& s : stored) {
      done[s.participant][s.ordinal] = s.state_after;
      // The state a virtual trainee resumes from, checked before any work (an edited one was a
      // segfault or an "internal error").
      if (s.trainee == "human") continue;
      const auto j = nlohmann::json::parse(s.state_after, nullptr, false);
      std::string problems;
      if (j.is_discarded()) {
        problems =
            "text that is not JSON: " +
            nlohmann::json(s.state_after.substr(0, 40) + (s.state_after.size() > 40 ? "..." : ""))
                .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
      } else {
        // The one validator; the problems are said by JSON path (the column's line:column says
        // nothing more in one line of JSON).
        palplab::json::Checker c("state_after", s.state_after);
        (void)pm::TraineeState::from_json(j, c);
        for (const auto& p : c.problems())
          problems += (problems.empty() ? "" : "; ") + p.where.json_path + ": " + p.what;
      }
      if (!problems.empty())
        throw InputError("table sessions, row (session " + std::to_string(s.session) +
                             ", participant " + s.participant + ", phase " + s.phase +
                             ") column state_after: " + problems +
                             " (not the virtual trainee's state palplab run wrote); resume needs "
                             "the database palplab run wrote",
                         opt.db);
    }
    // Sessions are written in order per participant: what is stored must be the first k of the
    // plan's sessions of a planned participant (a row deleted or edited by hand would otherwise
    // make the resumed run write an ordinal that exists: an SQL error after simulating).
    for (const auto& [participant, ordinals] : done) {
      const auto pp = std::find_if(plan.participants.begin(), plan.participants.end(),
                                   [&](const ParticipantPlan& q) { return q.id == participant; });
      if (pp == plan.participants.end())
        throw InputError("inconsistent database: it holds sessions of participant \"" +
                             participant +
                             "\", who is not in the plan; resume needs the database "
                             "palplab run wrote",
                         opt.db);
      int expect = 0;
      for (const auto& [ordinal, state] : ordinals) {
        if (ordinal != expect || ordinal >= static_cast<int>(pp->sessions.size()))
          throw InputError(
              "inconsistent database: participant " + participant + " has session ordinal " +
                  std::to_string(ordinal) + " but " +
                  (ordinal >= static_cast<int>(pp->sessions.size())
                       ? "the plan has " + std::to_string(pp->sessions.size()) + " sessions"
                       : "not ordinal " + std::to_string(expect)) +
                  " (sessions are written in order); resume needs the database "
                  "palplab run wrote",
              opt.db);
        ++expect;
      }
    }
    for (const auto& s : store.read_attempts())
      if (s.trainee == "human") human.insert(s.participant);
    for (const auto& p : store.read_prototypes()) {
      prototype_sha[p.prototype] = p.sha256;
      auto it = study.prototype_files.find(p.prototype);
      if (it == study.prototype_files.end() || prototype_sha256(it->second) != p.sha256)
        throw InputError("prototype \"" + p.prototype +
                             "\" differs from the file the run started with, or its mesh.file "
                             "does (SHA-256); resume needs identical prototypes and meshes",
                         it == study.prototype_files.end() ? opt.db : it->second);
    }
  } else {
    write_new_study(study, plan, sha, store, prototype_sha, keep_samples);
  }

  Progress progress;
  progress.participants_total = static_cast<int>(plan.participants.size());
  progress.sessions_total = static_cast<long>(plan.session_count());
  for (const auto& p : plan.participants)
    if (human.count(p.id)) progress.sessions_total -= static_cast<long>(p.sessions.size());
  for (const auto& [p, m] : done)
    if (!human.count(p)) progress.sessions_resumed += static_cast<long>(m.size());
  progress.sessions_done = progress.sessions_resumed;
  for (const auto& p : plan.participants)
    if (done.count(p.id) && done[p.id].size() == p.sessions.size()) ++progress.participants_done;

  // Simulated time left per prototype, and the wall time and simulated time of the sessions
  // run so far (for Progress::eta).
  struct PrototypeCost {
    double left = 0.0, wall = 0.0, simulated = 0.0;
  };
  std::map<std::string, PrototypeCost> cost;
  std::map<std::string, std::size_t> sessions_left;  // per participant id
  for (const auto& p : plan.participants) {
    if (human.count(p.id)) continue;
    const auto it = done.find(p.id);
    for (const auto& ss : p.sessions)
      if (it == done.end() || !it->second.count(ss.ordinal)) {
        cost[ss.prototype].left += ss.duration;
        ++sessions_left[p.id];
      }
  }
  for (const auto& r : stored)  // the costs measured by the earlier run(s) of this database
    if (r.trainee == "virtual" && r.status == "complete" && cost.count(r.prototype)) {
      cost[r.prototype].wall += r.wall_duration;
      cost[r.prototype].simulated += r.duration;
    }
  RunSummary sum;
  sum.sessions_skipped = progress.sessions_resumed;
  auto update_eta = [&] {
    double work = 0.0;
    progress.eta_untimed.clear();
    std::set<std::string> untimed;
    long busy = 0;  // participants with sessions left: at most one thread each
    if (opt.max_sessions > 0) {
      // To the --max-sessions stop: the next sessions not yet done, in plan order (each
      // participant's in its order; with several threads this is the approximate set).
      long n = opt.max_sessions - sum.sessions_run;
      for (const auto& p : plan.participants) {
        if (n <= 0) break;
        const auto it = sessions_left.find(p.id);
        if (it == sessions_left.end() || it->second == 0) continue;
        ++busy;
        for (std::size_t k = p.sessions.size() - it->second; k < p.sessions.size() && n > 0;
             ++k, --n) {
          const PrototypeCost& c = cost[p.sessions[k].prototype];
          if (c.simulated > 0.0)
            work += p.sessions[k].duration * c.wall / c.simulated;
          else
            untimed.insert(p.sessions[k].prototype);
        }
      }
    } else {
      for (const auto& [id, c] : cost) {
        if (c.left <= 0.0) continue;
        if (c.simulated > 0.0)
          work += c.left * c.wall / c.simulated;
        else
          untimed.insert(id);
      }
      for (const auto& [id, n] : sessions_left) busy += n > 0 ? 1 : 0;
    }
    for (const auto& id : untimed)
      progress.eta_untimed += (progress.eta_untimed.empty() ? "" : ", ") + id;
    progress.eta = !progress.eta_untimed.empty()
                       ? -1.0
                       : work / static_cast<double>(std::max(1L, std::min<long>(opt.jobs, busy)));
  };

  const ModelParams mp(study);
  std::mutex mu;
  std::atomic<std::size_t> next{0};
  std::atomic<long> started{0};
  std::atomic<bool> stop{false};
  std::exception_ptr error;

  auto worker = [&] {
    while (!stop) {
      const std::size_t i = next++;
      if (i >= plan.participants.size()) return;
      const ParticipantPlan& pp = plan.participants[i];
      if (human.count(pp.id)) continue;
      try {
        pm::TraineeState state;
        std::size_t k = 0;
        auto it = done.find(pp.id);
        if (it != done.end()) {
          // Sessions are stored in order per participant; continue after the last one.
          while (k < pp.sessions.size() && it->second.count(static_cast<int>(k))) ++k;
          if (k > 0)
            state = pm::TraineeState::from_json(
                nlohmann::json::parse(it->second.at(static_cast<int>(k - 1))));
        }
        for (; k < pp.sessions.size() && !stop; ++k) {
          if (opt.max_sessions > 0 && started++ >= opt.max_sessions) {
            stop = true;
            break;
          }
          const auto session_t0 = Clock::now();
          const bool tracing = !opt.record_trace_dir.empty();
          SessionOutcome o = run_session(study, mp, pp, pp.sessions[k], state,
                                         keep_samples || tracing, prototype_sha, tracing);
          if (tracing) {
            engine::Trace tr =
                o.track.samples.empty() ? trace_from_samples(o.data.samples) : std::move(o.track);
            tr.meta = {{"participant", pp.id},
                       {"ordinal", std::to_string(pp.sessions[k].ordinal)},
                       {"prototype", pp.sessions[k].prototype},
                       {"source", "virtual participant (exact positions)"},
                       {"database", trace_database(opt.db)},
                       {"study", study.id}};
            fs::create_directories(opt.record_trace_dir);
            engine::write_trace(
                (fs::path(opt.record_trace_dir) /
                 (pp.id + "_" + std::to_string(pp.sessions[k].ordinal) + "_0.trace"))
                    .string(),
                tr);
            if (!keep_samples) o.data.samples = results::SampleSeries{};
          }
          store.write_session(o.data);
          const double whole = std::chrono::duration<double>(Clock::now() - session_t0).count();
          state = o.state_after;
          std::lock_guard lock(mu);
          ++sum.sessions_run;
          sum.simulated += o.data.session.duration;
          PrototypeCost& c = cost[pp.sessions[k].prototype];
          c.left -= pp.sessions[k].duration;
          c.wall += whole;  // the whole session, not only its stepping loop (wall_duration)
          c.simulated += o.data.session.duration;
          --sessions_left[pp.id];
          progress.last_session_wall = whole;
          update_eta();
          ++progress.sessions_done;
          progress.simulated = sum.simulated;
          if (k + 1 == pp.sessions.size()) ++progress.participants_done;
          progress.last = pp.id + " " + pp.sessions[k].phase_id + " #" +
                          std::to_string(pp.sessions[k].index + 1);
          progress.elapsed = std::chrono::duration<double>(Clock::now() - t0).count();
          if (opt.progress) opt.progress(progress);
        }
      } catch (...) {
        std::lock_guard lock(mu);
        if (!error) error = std::current_exception();
        stop = true;
      }
    }
  };
  const int jobs = std::max(1, opt.jobs);
  std::vector<std::thread> threads;
  for (int j = 0; j < jobs; ++j) threads.emplace_back(worker);
  for (auto& t : threads) t.join();
  if (error) std::rethrow_exception(error);

  sum.wall = std::chrono::duration<double>(Clock::now() - t0).count();
  // Human participants finish on their own schedule: the study is finished when every planned
  // session is complete, whoever ran it (run_human marks it when a person's is the last; before,
  // a database with any person's session was never marked finished, its report "provisional").
  sum.left = participants_left(plan, store);
  for (const auto& id : sum.left)
    if (human.count(id)) sum.people_left.push_back(id);
  sum.complete = sum.left.empty();
  if (sum.complete) store.set_finished(results::utc_now());
  return sum;
}

namespace {

std::int64_t parse_utc(const std::string& iso) {
  std::tm tm{};
  if (!strptime(iso.c_str(), "%Y-%m-%dT%H:%M:%SZ", &tm)) return -1;
  return static_cast<std::int64_t>(timegm(&tm));
}

std::string utc_date(std::int64_t t) {
  const std::time_t tt = static_cast<std::time_t>(t);
  std::tm tm{};
  gmtime_r(&tt, &tm);
  char buf[16];
  std::strftime(buf, sizeof buf, "%Y-%m-%d", &tm);
  return buf;
}

std::string utc_iso(std::int64_t t) {
  const std::time_t tt = static_cast<std::time_t>(t);
  std::tm tm{};
  gmtime_r(&tt, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace

engine::Trace trace_from_samples(const results::SampleSeries& s) {
  engine::Trace tr;
  tr.meta["source"] = "database samples (positions quantised to 1 um)";
  for (std::size_t i = 0; i < s.size(); ++i) {
    engine::TraceSample ts;
    ts.t = s.t0 + static_cast<double>(i) * s.dt;
    ts.in.position = Eigen::Vector3d(s.x[3 * i], s.x[3 * i + 1], s.x[3 * i + 2]);
    tr.samples.push_back(ts);
  }
  return tr;
}

namespace {
// Whole seconds, or three significant digits below 10 s (a 0.05 s session is not "0 s").
std::string seconds_text(double s) {
  if (s >= 10.0) return std::to_string(std::lround(s));
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", s);
  return buf;
}
}  // namespace

std::string session_instructions(const Study& study, const SessionSpec& spec) {
  if (spec.phase >= 0 && spec.phase < static_cast<int>(study.phases.size()))
    if (const std::string* t = study.phases[spec.phase].instructions_for(spec.index)) return *t;
  if (study.task.kind == "needle_insertion")
    return "Palpate the skin with the finger to choose the entry point, then take the needle "
           "(device button 2, or N in the window) and insert it to the " +
           study.task.feature + ". The session lasts " + seconds_text(spec.duration) + " s.";
  return "Palpate the model and find the " + study.task.feature + ". The session lasts " +
         seconds_text(spec.duration) + " s.";
}

// The system clock, Unix s with its fraction.
double unix_seconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

HumanSummary run_human(const Study& study, const Plan& plan, const HumanOptions& opt) {
  auto say = [&](const std::string& m) {
    if (opt.say) opt.say(m);
  };
  const ParticipantPlan* pp = &plan.participant(opt.participant);
  // "Now": the system clock, or one that starts at the tests' and dry runs' PALPLAB_NOW and
  // runs with it, for every time stored (the study's start and end, each session's).
  const double started = unix_seconds();
  auto now_exact = [&] {  // s, to the clock's resolution
    const double t = unix_seconds();
    return opt.now >= 0 ? static_cast<double>(opt.now) + (t - started) : t;
  };
  auto now = [&] { return static_cast<std::int64_t>(std::floor(now_exact())); };
  const std::string sha = results::sha256_hex(study.json_text);
  std::map<std::string, std::string> prototype_sha;
  bool exists = fs::exists(opt.db);
  if (exists && results::Store::remove_empty_leftover(opt.db)) {  // as run_study's --resume
    say("note: " + opt.db + " holds no run yet (its start was interrupted): starting the run");
    exists = false;
  }
  results::Store store =
      exists ? results::Store::open(opt.db, true) : results::Store::create(opt.db);
  if (exists && interrupted_start(store, opt.db, "continue it")) {
    say("note: " + opt.db + " holds no run yet (its start was interrupted): starting the run");
    exists = false;
  }
  bool keep_samples = opt.samples;
  if (exists) {
    results::StudyRecord rec = store.read_study();
    if (rec.sha256 != sha)
      throw InputError(another_study(rec, study, sha,
                                     "human sessions need the identical study file (to run this "
                                     "one: another --db)"),
                       opt.db);
    keep_samples = run_samples_setting(store, store.read_sessions(), opt.samples,
                                       opt.samples_explicit, opt.db);
    for (const auto& p : store.read_prototypes()) prototype_sha[p.prototype] = p.sha256;
  } else {
    write_new_study(study, plan, sha, store, prototype_sha, keep_samples, utc_iso(now()));
  }
  if (int n = store.abort_stale_sessions(pp->id))
    say("note: " + std::to_string(n) + " session(s) of " + pp->id +
        " left running by an ended process are marked aborted");

  std::map<int, int> attempts;  // ordinal -> attempts so far
  std::set<int> complete;
  // ordinal -> when its complete attempt ended (Unix s; stored ones to the next whole second,
  // as stored times are whole seconds; this run's exactly)
  std::map<int, double> ended;
  std::int64_t first_start = -1;     // of any attempt: day 0 is that day
  std::int64_t first_complete = -1;  // of a complete session: study_offset counts from it
  for (const auto& r : store.read_attempts(pp->id)) {
    if (r.trainee != "human")
      throw InputError("participant " + pp->id +
                           " was simulated (virtual) in this database; a participant is either "
                           "human or virtual",
                       opt.db);
    attempts[r.ordinal] = std::max(attempts[r.ordinal], r.attempt + 1);
    const std::int64_t t = parse_utc(r.started_at);
    if (t >= 0 && (first_start < 0 || t < first_start)) first_start = t;
    if (r.status == "complete") {
      complete.insert(r.ordinal);
      if (const std::int64_t e = parse_utc(r.completed_at); e >= 0) ended[r.ordinal] = e + 1.0;
      if (t >= 0 && (first_complete < 0 || t < first_complete)) first_complete = t;
    }
  }
  auto day_of = [](std::int64_t t) { return t >= 0 ? t / 86400 : 0; };
  const std::int64_t day0 = day_of(first_start >= 0 ? first_start : now());

  HumanSummary sum;
  for (const SessionSpec& spec : pp->sessions) {
    if (complete.count(spec.ordinal)) continue;
    const std::int64_t due_day = day0 + spec.day;
    if (due_day > day_of(now())) {
      sum.next_due = utc_date(due_day * 86400);
      if (sum.sessions_run == 0 && sum.aborted == 0)
        throw InputError("participant " + pp->id + ": nothing is due today (" + utc_date(now()) +
                         "); the next session (" + spec.phase_id + " #" +
                         std::to_string(spec.index + 1) + ", day " + std::to_string(spec.day) +
                         " of the study) is due on " + sum.next_due);
      break;
    }
    // A missed day's session runs first, said (it ran without a word: review 2026-12-07).
    if (due_day < day_of(now()))
      say("note: " + spec.phase_id + " #" + std::to_string(spec.index + 1) +
          " was planned on day " + std::to_string(spec.day) + " of the study (" +
          utc_date(due_day * 86400) + "); it was missed and runs now, on day " +
          std::to_string(day_of(now()) - day0));
    if (auto it = prototype_sha.find(spec.prototype);
        it != prototype_sha.end() && prototype_sha256(spec.prototype_file) != it->second)
      throw InputError(
          "prototype file or its mesh.file changed since the study's database was created "
          "(SHA-256 differs); restore it or start a new database",
          spec.prototype_file);
    // The study's break before this session, counted from the end of the one before it when
    // both are planned on one day (they ran back to back before: review 2026-12-07).
    if (&spec != &pp->sessions.front()) {
      const SessionSpec& prev = *(&spec - 1);
      const double planned = spec.offset - (prev.offset + prev.duration);
      const auto it = ended.find(prev.ordinal);
      if (prev.day == spec.day && planned > 0 && it != ended.end()) {
        const double from = it->second + planned;
        if (now_exact() < from && opt.no_wait) {
          say("note: " + spec.phase_id + " #" + std::to_string(spec.index + 1) +
              " starts without the study's break of " + seconds_text(planned) +
              " s after the previous session (--no-wait)");
        } else if (now_exact() < from) {
          say("break: " + spec.phase_id + " #" + std::to_string(spec.index + 1) + " is planned " +
              seconds_text(planned) + " s after the previous session ended; it starts at " +
              utc_iso(static_cast<std::int64_t>(std::ceil(from))) +
              " (waiting; Ctrl-C stops, and the command run again continues)");
          while (now_exact() < from && !(opt.stop && opt.stop->load()))
            std::this_thread::sleep_for(std::chrono::milliseconds(100));
          if (opt.stop && opt.stop->load()) {
            sum.stopped = true;
            break;
          }
        }
      }
    }
    say("instructions: " + session_instructions(study, spec));
    if (opt.before_session && !opt.before_session(spec)) {
      sum.stopped = true;
      break;
    }
    engine::Scene scene = session_scene(study, spec);
    const engine::SceneGeometry& g = scene.geometry();
    const bool needle = study.task.kind == "needle_insertion";
    if (needle && scene.tool() == "probe")
      throw InputError("prototype \"" + spec.prototype + "\" (model \"" + scene.model_kind() +
                           "\") has no finger and needle tools; a needle_insertion task needs "
                           "model \"needle\"",
                       spec.prototype_file);
    if (!needle && g.region_index(study.task.feature) < 0)
      throw InputError(
          "prototype \"" + spec.prototype + "\" has no region \"" + study.task.feature + "\"",
          spec.prototype_file);
    std::unique_ptr<engine::Device> dev;
    try {
      dev = opt.make_device();
    } catch (const InputError& e) {
      // A device that fails its self-test before a later session: the sessions this command
      // completed are stored; say so with the error (it ended without its summary).
      if (sum.sessions_run == 0) throw;
      std::vector<Problem> ps = e.problems();
      int left = 0;
      for (const auto& sp : pp->sessions) left += !complete.count(sp.ordinal);
      ps.back().what += "; before it this command completed and stored " +
                        std::to_string(sum.sessions_run) + " session(s) of " + pp->id + ", " +
                        std::to_string(left) +
                        " remain (run the command again when the device works)";
      throw InputError(std::move(ps));
    }
    engine::TraceRecorder recorder(*dev);
    engine::Device& raw = opt.record_trace_dir.empty() ? static_cast<engine::Device&>(*dev)
                                                       : static_cast<engine::Device&>(recorder);
    // A needle scene's tool and stylus axis come from the device (buttons bit 1, stylus_axis),
    // set on the haptic thread before each step (engine/haptics/devices/tool_switch.hpp).
    engine::ToolSwitchDevice tools(raw, scene);
    engine::Device& device = needle ? static_cast<engine::Device&>(tools) : raw;

    results::SessionData data;
    results::SessionRecord& rec = data.session;
    rec.participant = pp->id;
    rec.ordinal = spec.ordinal;
    rec.phase = spec.phase_id;
    rec.phase_index = spec.index;
    rec.prototype = spec.prototype;
    rec.instructor = spec.instructor;
    // When it started, after the participant's first session started (the plan's offset is
    // what a virtual participant keeps; a person keeps the real time).
    if (first_complete < 0) first_complete = now();
    rec.study_offset = static_cast<double>(now() - first_complete);
    rec.day = spec.day;
    rec.seed = spec.seed;
    rec.state_after = "{\"trainee\":\"human\"}";
    rec.attempt = attempts[spec.ordinal];
    rec.trainee = "human";
    rec.device = opt.device_text;
    rec.transparency = scene.config().cues.transparency;
    rec.started_at = utc_iso(now());
    store.begin_session(rec);
    say("session " + spec.phase_id + " #" + std::to_string(spec.index + 1) + " (" +
        std::to_string(std::lround(spec.duration)) + " s, prototype " + spec.prototype +
        ") started");

    // The haptic thread appends to `pending`; this thread moves whole seconds to the store.
    std::mutex mu;
    results::SampleSeries pending;
    pending.dt = scene.dt();
    std::vector<results::EventRecord> pending_events;
    results::SampleSeries all;  // the whole log, for the measures
    all.dt = scene.dt();
    std::vector<results::EventRecord> all_events;
    std::atomic<bool> stop{false};
    std::atomic<bool> finished{false};
    engine::RealtimeOptions ro;
    ro.duration = spec.duration;
    ro.frame_period = opt.on_frame ? 1.0 / 60.0 : 0.05;  // a window draws at 60 Hz
    ro.stop = &stop;
    const auto names = g.region_names;
    ro.on_step = [&](const engine::Rendered& r, const engine::Sample& smp) {
      std::lock_guard lock(mu);
      // The force the hand got: none while the device is timed out (the simulator's force on a
      // stale position was logged and measured, review 2026-12-07).
      if (device.force_withheld()) {
        engine::Sample got = smp;
        got.F.setZero();
        log_step(r, got, names, pending, pending_events);
      } else {
        log_step(r, smp, names, pending, pending_events);
      }
    };
    if (opt.on_session_start) opt.on_session_start(spec, scene);
    const auto wall0 = Clock::now();
    engine::RealtimeStats stats;
    std::thread loop([&] {
      stats = engine::run_realtime(scene, device, ro, opt.on_frame);
      finished = true;
    });
    std::string reason;
    long long second = 0;
    long last_samples = dev->samples_received();
    auto last_fresh = Clock::now();
    auto flush = [&](bool final) {
      results::SampleSeries chunk;
      std::vector<results::EventRecord> ev;
      {
        std::lock_guard lock(mu);
        const std::size_t per = static_cast<std::size_t>(std::llround(1.0 / pending.dt));
        const std::size_t n = final ? pending.size() : pending.size() / per * per;
        chunk.dt = pending.dt;
        chunk.t0 = static_cast<double>(second) * 1.0;
        chunk.x.assign(pending.x.begin(), pending.x.begin() + 3 * n);
        chunk.F.assign(pending.F.begin(), pending.F.begin() + 3 * n);
        chunk.node.assign(pending.node.begin(), pending.node.begin() + n);
        pending.x.erase(pending.x.begin(), pending.x.begin() + 3 * n);
        pending.F.erase(pending.F.begin(), pending.F.begin() + 3 * n);
        pending.node.erase(pending.node.begin(), pending.node.begin() + n);
        ev.swap(pending_events);
      }
      for (auto& e : dev->take_events()) ev.push_back({e.t, e.kind, e.value, ""});
      if (chunk.size() == 0 && ev.empty()) return;
      store.append_session_data(rec.session, ev, keep_samples ? chunk : results::SampleSeries{},
                                second, static_cast<long long>(all.size() + chunk.size()),
                                chunk.dt);
      all.x.insert(all.x.end(), chunk.x.begin(), chunk.x.end());
      all.F.insert(all.F.end(), chunk.F.begin(), chunk.F.end());
      all.node.insert(all.node.end(), chunk.node.begin(), chunk.node.end());
      all_events.insert(all_events.end(), ev.begin(), ev.end());
      second += static_cast<long long>((chunk.size() + 999) / 1000);
    };
    while (!finished) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      if (opt.stop && opt.stop->load() && !stop) {
        reason = opt.stop_reason ? opt.stop_reason() : "interrupted";
        stop = true;
      }
      const long got = dev->samples_received();
      if (got >= 0) {
        if (got != last_samples) {
          last_samples = got;
          last_fresh = Clock::now();
        } else if (!stop && std::chrono::duration<double>(Clock::now() - last_fresh).count() >
                                opt.device_lost) {
          reason = "device " + opt.device_text + " lost: no position for " +
                   std::to_string(opt.device_lost) + " s";
          stop = true;
        }
      }
      flush(false);
    }
    loop.join();
    flush(true);
    const long planned = std::lround(spec.duration / scene.dt());
    if (reason.empty() && stats.steps < planned)
      reason = "the device stream ended after " + std::to_string(stats.steps) + " of " +
               std::to_string(planned) + " steps";
    // Event times are the scene's; the device's events use the same simulated time.
    std::stable_sort(all_events.begin(), all_events.end(),
                     [](const auto& a, const auto& b) { return a.t < b.t; });
    data.measures = session_measures(study, g, all, all_events);
    rec.duration = static_cast<double>(stats.steps) * scene.dt();
    rec.steps = stats.steps;
    rec.wall_duration = std::chrono::duration<double>(Clock::now() - wall0).count();
    rec.loop_median = stats.period_median_us * 1e-6;
    rec.loop_p99 = stats.period_p99_us * 1e-6;
    rec.status = reason.empty() ? "complete" : "aborted";
    rec.abort_reason = reason;
    rec.completed_at = utc_iso(now());  // PALPLAB_NOW's clock too (it was the system's)
    store.finish_session(data);
    if (opt.on_session_end) opt.on_session_end(rec);
    if (!opt.record_trace_dir.empty()) {
      fs::create_directories(opt.record_trace_dir);
      engine::Trace tr = recorder.trace();
      tr.meta["participant"] = pp->id;
      tr.meta["ordinal"] = std::to_string(spec.ordinal);
      tr.meta["prototype"] = spec.prototype;
      tr.meta["database"] = trace_database(opt.db);
      tr.meta["study"] = study.id;
      engine::write_trace(
          (fs::path(opt.record_trace_dir) / (pp->id + "_" + std::to_string(spec.ordinal) + "_" +
                                             std::to_string(rec.attempt) + ".trace"))
              .string(),
          tr);
    }
    say("session " + spec.phase_id + " #" + std::to_string(spec.index + 1) + " " + rec.status +
        (reason.empty() ? "" : " (" + reason + ")") + ", loop period median " +
        std::to_string(stats.period_median_us) + " us, p99 " + std::to_string(stats.period_p99_us) +
        " us");
    if (!reason.empty()) {
      ++sum.aborted;
      sum.abort_reason = reason;
      break;
    }
    ++sum.sessions_run;
    complete.insert(spec.ordinal);
    ended[spec.ordinal] = now_exact();
  }
  for (const auto& spec : pp->sessions)
    if (!complete.count(spec.ordinal)) {
      ++sum.remaining;
      if (sum.next_due.empty()) sum.next_due = utc_date((day0 + spec.day) * 86400);
    }
  // This person's last session may be the study's last (as run_study marks it).
  if (sum.remaining == 0 && participants_left(plan, store).empty())
    store.set_finished(utc_iso(now()));
  return sum;
}

std::string trace_database(const std::string& db) {
  std::error_code ec;
  const fs::path p = fs::weakly_canonical(fs::absolute(db), ec);
  return ec ? fs::absolute(db).lexically_normal().string() : p.string();
}

void require_trace_dir_of(const std::string& dir, const std::string& db) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return;                               // made by the run
  const std::string mine = escape_controls(trace_database(db), false);  // as write_trace writes it
  static const std::regex name(R"(.+_[0-9]+_[0-9]+\.trace)");
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (std::regex_match(e.path().filename().string(), name)) files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    // Never opened unless a regular file: a pipe of such a name would block the open.
    if (!fs::is_regular_file(f, ec))
      throw InputError(SourceLocation{"--record-trace"},
                       "\"" + dir + "\" holds " + f +
                           ", which is no regular file (a pipe, a device or a directory), with "
                           "a name this run writes: choose another directory (one per database)");
    const auto meta = engine::read_trace_meta(f);
    const auto it = meta.find("database");
    if (it != meta.end() && it->second == mine) continue;
    throw InputError(
        SourceLocation{"--record-trace"},
        "\"" + dir + "\" holds " + f + ", " +
            (meta.empty() ? std::string("a file that is no palplab trace")
             : it == meta.end()
                 ? std::string("a trace that does not name its run (an older palplab's, or one "
                               "written by hand)")
                 : "a trace of another run (database " + it->second + ")") +
            ", with a name this run writes: its sessions' tracks would replace such files; "
            "choose another directory (one per database)");
  }
}

}  // namespace palplab::protocols
