#pragma once
// A study as a researcher writes it (docs/FORMATS.md): groups, a timeline of phases, the
// task and its force thresholds, roles, measures, participant model and analyses. load_study()
// validates the whole file and the prototype files it names and reports ALL problems at once
// (palplab::InputError, one Problem per finding, FILE:LINE:COL: $.json.path: what was expected).
//
// Units: forces N, durations and offsets s (the JSON may say minutes/hours/days where noted).
#include <cstdint>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "engine/haptics/scene.hpp"

namespace palplab::protocols {

inline constexpr int kStudyFormatVersion = 1;

// Force limits of a region: the engine's type (ST, MPF, SFT in N).
using ForceLimits = engine::Thresholds;

struct CueSwitches {
  std::optional<bool> haptic, visual_deformation, audio;  // unset = as the prototype says
  std::optional<bool> transparency;  // needle scenes: soft tissue see-through (tip visible)
};

struct Task {
  // "palpation" (find the feature, press to its MPF) or "needle_insertion" (palpate the skin
  // with the finger, choose the entry point, insert the needle to the target tissue `feature`;
  // docs/FORMATS.md "Needle insertion studies").
  std::string kind = "palpation";
  std::string scene;    // informational; checked against the prototype's "scene" when it has one
  std::string feature;  // region name of the feature to find (e.g. "ovary_left")
  // needle_insertion: what the briefing tells the trainee (an atlas description): the entry
  // point on the skin (m, the prototype's frame) and the depth of the target below it (m).
  Eigen::Vector3d entry_hint = Eigen::Vector3d::Zero();
  double target_depth_hint = 0.0;
  // Region name -> limits; "*" applies to every region without its own entry.
  std::map<std::string, ForceLimits> thresholds;
  double accuracy_tolerance = 0.25;  // N: a palpation is accurate if |peak - MPF| <= this
  double identify_dwell = 0.2;       // s of continuous contact on the feature that identifies it
  double palpation_onset = 0.5;      // N: force above which a contact counts as a palpation
};

// A gap or start offset: either an elapsed time (s) or a number of calendar days (a session
// `days` later starts at the same clock time as the session it is counted from).
struct Interval {
  double seconds = 0.0;
  int days = 0;
  bool calendar = false;  // true: `days` is used; false: `seconds`
};

struct Phase {
  std::string id;
  std::string kind;  // "pre_training" | "training" | "post_training" | "other" (descriptive)
  int sessions = 1;
  double session_duration = 0.0;  // s
  // Start of the phase's first session: on day `start_day` (0 = the participant's first day,
  // same clock time), or `start_after` after the END of the previous phase's last session.
  std::optional<int> start_day;
  Interval start_after;
  Interval gap;  // between consecutive sessions: calendar days start-to-start, else end-to-start
  std::optional<std::string> prototype;  // the same prototype for every group in this phase
  CueSwitches cues;
  bool instructed = false;  // an instructor guides this phase's sessions (roles.instructor)
  // What a person is told before each session (`run --human`): empty = a default from the task,
  // one text = every session of the phase, else one per session.
  std::vector<std::string> instructions;
  const std::string* instructions_for(int session_index) const {
    if (instructions.empty()) return nullptr;
    return &instructions[instructions.size() == 1 ? 0 : static_cast<std::size_t>(session_index)];
  }
};

struct Group {
  std::string id;
  std::string prototype;                        // default prototype id
  std::map<std::string, std::string> by_phase;  // phase id -> prototype id
  int size = 0;
  std::vector<std::string> participants;  // explicit assignment only
};

struct InstructorRole {
  std::vector<std::string> ids;
  // group id -> instructor per instructed session, in session order across instructed phases
  std::map<std::string, std::vector<std::string>> assignment;
  nlohmann::json parameters = nlohmann::json::object();  // instructor model parameters
};

struct Analysis {
  std::string kind;     // "anova_oneway" | "pairwise_t" | "descriptives"
  std::string measure;  // a measure name
  std::string phase;    // phase id whose sessions are analysed
  bool welch = true;    // pairwise_t: unequal variances (MINITAB default)
  bool pooled = false;  // pool all sessions of the phase (experiment 1) instead of the last one
  // pooled: participant means by default; true treats every session as an independent
  // observation (pseudo-replication; `validate` and the report warn)
  bool pool_sessions = false;
  double margin = 0.0;  // equivalence margin ± in the measure's unit; 0 = the report's default
};

// A declared (confirmatory) hypothesis, $.hypotheses[i]: the report runs exactly these first.
struct Hypothesis {
  std::string id;              // label ("H1")
  std::string statement;       // optional free text
  std::string measure, phase;  // what and where (as in Analysis)
  std::string test;            // "anova_oneway" | "welch_t" | "student_t" | "tost"
  std::vector<std::pair<std::string, std::string>> pairs;  // group pairs; empty = all pairs
  std::optional<std::pair<double, double>> margins;        // tost: [low, high] in measure units
  double alpha = 0.05;
  std::string correction = "holm";  // over the hypothesis's pairs: "holm" | "bonferroni" | "none"
  bool pooled = false;              // participant means over the phase's sessions, else the last
};

// Participants x sessions each that one study may plan (the validator's limit; power and
// calibrate hold a resized study to it too): beyond it a study is a typo that would take all
// memory.
inline constexpr long long kMaxPlannedSessions = 1000000;
// The longest session (24 h of 1 kHz samples) and the largest task force (as the thresholds,
// prototypes::read_thresholds) a study may declare: also the bounds of a measured time and force
// in people's data (calibrate --human).
inline constexpr double kMaxSessionSeconds = 86400;  // s
inline constexpr double kMaxTaskForce = 1e6;         // N

struct Study {
  std::string file;       // path it was loaded from
  std::string json_text;  // the exact bytes (hashed and stored with results)
  std::string id, title, description;
  std::uint64_t seed = 0;
  Task task;
  std::vector<Group> groups;
  std::string assignment = "balanced_random";  // or "explicit"
  std::vector<Phase> phases;
  std::optional<InstructorRole> instructor;
  std::vector<std::string> measures;
  std::string participant_model = "pmm1";
  nlohmann::json participant_parameters = nlohmann::json::object();
  std::vector<Analysis> analyses;
  std::vector<Hypothesis> hypotheses;
  std::vector<std::string> prototype_dirs;  // extra search dirs, resolved against the study dir
  // Prototype id -> resolved file path (every id the study names).
  std::map<std::string, std::string> prototype_files;
};

// The measure names palplab computes (units: N, s, 0/1, %, mm), and the default set of a task
// kind (palpation / needle_insertion) when a study lists none.
const std::vector<std::string>& known_measures();
const std::vector<std::string>& default_measures(const std::string& task_kind);
std::string measure_unit(const std::string& measure);

// What the validator needs to know about a prototype beyond "the file exists and is JSON":
// the region names its scene provides. The default asks the engine (prototypes::build_scene);
// tests may pass their own. Throws palplab::InputError for a bad prototype file.
struct PrototypeInfo {
  std::vector<std::string> region_names;
  std::string scene;                       // may be empty
  std::string id;                          // the file's "id" (may be empty: not checked)
  std::vector<std::string> inner_regions;  // no vertex on the surface: never a palpation feature
  double dt = 0.0;                         // s, the haptic step (0: not known, not checked)
};
using PrototypeInspector = std::function<PrototypeInfo(const std::string& prototype_path)>;
PrototypeInspector engine_prototype_inspector();

// Reads, validates and returns the study; throws palplab::InputError listing every problem.
Study load_study(const std::string& path, const PrototypeInspector& inspect);
Study parse_study(const std::string& json_text, const std::string& file,
                  const PrototypeInspector& inspect);

}  // namespace palplab::protocols
