#include "protocols/plan.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>
#include <utility>

#include "common/input_error.hpp"
#include "common/seed.hpp"
#include "protocols/rng.hpp"

namespace palplab::protocols {

namespace {
constexpr double kDay = 86400.0;

std::string fmt_offset(double s) {
  int day = static_cast<int>(std::floor(s / kDay));
  double rest = s - day * kDay;
  char buf[64];
  std::snprintf(buf, sizeof buf, "day %d +%02d:%02d:%02d", day, static_cast<int>(rest / 3600),
                static_cast<int>(std::fmod(rest, 3600) / 60),
                static_cast<int>(std::fmod(rest, 60)));
  return buf;
}
}  // namespace

std::vector<Slot> schedule(const std::vector<Phase>& phases,
                           std::vector<ScheduleProblem>* problems) {
  std::vector<Slot> out;
  double prev_start = 0.0, prev_end = 0.0;
  for (std::size_t pi = 0; pi < phases.size(); ++pi) {
    const Phase& p = phases[pi];
    for (int k = 0; k < p.sessions; ++k) {
      double start;
      if (k == 0) {
        if (p.start_day)
          start = *p.start_day * kDay;
        else if (out.empty())
          start = 0.0;
        else if (p.start_after.calendar)
          start = prev_start + p.start_after.days * kDay;
        else
          start = prev_end + p.start_after.seconds;
      } else {
        start = p.gap.calendar ? prev_start + p.gap.days * kDay : prev_end + p.gap.seconds;
      }
      if (!out.empty() && start < prev_end - 1e-9 && problems)
        problems->push_back({static_cast<int>(pi), k == 0 ? "start" : "gap",
                             "session " + std::to_string(k + 1) + " of phase \"" + p.id +
                                 "\" would start at " + fmt_offset(start) +
                                 ", before the previous session ends (" + fmt_offset(prev_end) +
                                 "); expected a later start"});
      Slot s;
      s.phase = static_cast<int>(pi);
      s.index = k;
      s.offset = start;
      s.duration = p.session_duration;
      s.day = static_cast<int>(std::floor(start / kDay + 1e-12));
      out.push_back(s);
      prev_start = start;
      prev_end = start + p.session_duration;
    }
  }
  return out;
}

std::size_t Plan::session_count() const {
  std::size_t n = 0;
  for (const auto& p : participants) n += p.sessions.size();
  return n;
}

double Plan::simulated_seconds() const {
  double t = 0;
  for (const auto& p : participants)
    for (const auto& s : p.sessions) t += s.duration;
  return t;
}

const ParticipantPlan& Plan::participant(const std::string& id) const {
  for (const auto& p : participants)
    if (p.id == id) return p;
  std::string ids;
  for (const auto& p : participants) ids += (ids.empty() ? "" : ", ") + p.id;
  throw InputError("--participant: no participant \"" + id +
                   "\" in the study's plan (expected one of: " + ids + ")");
}

Plan make_plan(const Study& study) {
  Plan plan;
  // Participant -> group.
  std::vector<std::pair<std::string, int>> people;  // id, group index
  if (study.assignment == "explicit") {
    for (std::size_t g = 0; g < study.groups.size(); ++g)
      for (const auto& id : study.groups[g].participants)
        people.push_back({id, static_cast<int>(g)});
  } else {
    // Balanced random: exactly `size` places per group, shuffled (Fisher–Yates, own stream).
    std::vector<int> labels;
    for (std::size_t g = 0; g < study.groups.size(); ++g)
      for (int k = 0; k < study.groups[g].size; ++k) labels.push_back(static_cast<int>(g));
    Rng rng(derive_seed(study.seed, "assignment"));
    for (std::size_t i = labels.size(); i > 1; --i) std::swap(labels[i - 1], labels[rng.below(i)]);
    int width = std::max(2, static_cast<int>(std::to_string(labels.size()).size()));
    for (std::size_t n = 0; n < labels.size(); ++n) {
      std::string num = std::to_string(n + 1);
      people.push_back({"P" + std::string(width - num.size(), '0') + num, labels[n]});
    }
  }
  const auto slots = schedule(study.phases);
  for (std::size_t n = 0; n < people.size(); ++n) {
    ParticipantPlan pp;
    pp.id = people[n].first;
    const Group& g = study.groups[people[n].second];
    pp.group = g.id;
    pp.number = static_cast<int>(n);
    pp.seed = derive_seed(study.seed, label_hash("participant"), static_cast<std::uint64_t>(n));
    int instructed = 0;
    for (std::size_t k = 0; k < slots.size(); ++k) {
      const Slot& sl = slots[k];
      const Phase& ph = study.phases[sl.phase];
      SessionSpec s;
      s.ordinal = static_cast<int>(k);
      s.phase = sl.phase;
      s.phase_id = ph.id;
      s.index = sl.index;
      // Most specific wins: the group's per-phase prototype, then the phase's, then the group's.
      if (auto it = g.by_phase.find(ph.id); it != g.by_phase.end())
        s.prototype = it->second;
      else if (ph.prototype)
        s.prototype = *ph.prototype;
      else
        s.prototype = g.prototype;
      if (auto it = study.prototype_files.find(s.prototype); it != study.prototype_files.end())
        s.prototype_file = it->second;
      s.cues = ph.cues;
      s.offset = sl.offset;
      s.duration = sl.duration;
      s.day = sl.day;
      if (ph.instructed && study.instructor) {
        auto it = study.instructor->assignment.find(g.id);
        if (it != study.instructor->assignment.end() &&
            instructed < static_cast<int>(it->second.size()))
          s.instructor = it->second[instructed];
        ++instructed;
      }
      s.seed = derive_seed(pp.seed, label_hash("session"), static_cast<std::uint64_t>(k));
      pp.sessions.push_back(s);
    }
    plan.participants.push_back(std::move(pp));
  }
  return plan;
}

std::string plan_summary(const Study& study, const Plan& plan) {
  std::ostringstream o;
  o << "study " << study.id << ": " << study.title << "\n";
  o << "seed " << study.seed << ", " << plan.participants.size() << " participants, "
    << plan.session_count() << " sessions, " << plan.simulated_seconds() / 3600.0
    << " h simulated (lock-step at each prototype's haptic rate)\n";
  const bool needle = study.task.kind == "needle_insertion";
  if (needle) {
    // What a needle session does (protocols/needle_session.hpp): two tool phases in one session.
    const Eigen::Vector3d& e = study.task.entry_hint;
    o << "task: needle insertion into \"" << study.task.feature << "\"";
    if (!study.task.scene.empty()) o << " (scene " << study.task.scene << ")";
    o << "\n  1. tool finger: palpate the skin around the briefed entry point [" << e.x() << ", "
      << e.y() << ", " << e.z()
      << "] m, choose the entry point between the bony landmarks\n"
         "  2. tool needle: insert along the stylus axis to the target (briefed depth "
      << 1e3 * study.task.target_depth_hint
      << " mm); events tissue_entered/left, bone_contact, target_reached, tip_to_target\n"
         "  force limits (finger)";
  } else {
    o << "task: find \"" << study.task.feature << "\"";
  }
  bool first = true;
  for (auto& [r, l] : study.task.thresholds)
    o << (needle && std::exchange(first, false) ? ": " : "; ") << r << " ST " << l.st << " MPF "
      << l.mpf << " SFT " << l.sft << " N";
  o << "\ngroups (" << study.assignment << "):";
  for (const auto& g : study.groups) {
    o << " " << g.id << " n=" << g.size << " on " << g.prototype;
    for (auto& [ph, id] : g.by_phase) o << " (" << ph << ": " << id << ")";
    o << ";";
  }
  o << "\ntimeline per participant:\n";
  for (const auto& sl : schedule(study.phases)) {
    const Phase& p = study.phases[sl.phase];
    o << "  " << fmt_offset(sl.offset) << "  " << p.id << " #" << (sl.index + 1) << "  "
      << sl.duration << " s";
    if (p.prototype) o << "  prototype " << *p.prototype;
    std::string cues;
    auto cue = [&](const char* n, const std::optional<bool>& v) {
      if (v) cues += std::string(cues.empty() ? "" : ", ") + n + (*v ? " on" : " off");
    };
    cue("haptic", p.cues.haptic);
    cue("visual", p.cues.visual_deformation);
    cue("audio", p.cues.audio);
    cue("transparency", p.cues.transparency);
    if (!cues.empty()) o << "  cues: " << cues;
    if (p.instructed) o << "  instructed";
    o << "\n";
  }
  if (study.instructor) {
    o << "instructors:";
    for (auto& [g, l] : study.instructor->assignment) {
      o << " " << g << "→";
      for (std::size_t i = 0; i < l.size(); ++i) o << (i ? "," : "") << l[i];
    }
    o << "\n";
  }
  o << "prototypes:";
  for (auto& [id, f] : study.prototype_files) o << " " << id << "=" << f;
  o << "\nmeasures:";
  for (auto& m : study.measures) {
    o << " " << m;
    if (needle) o << " [" << measure_unit(m) << "]";
  }
  o << "\nanalyses:";
  // What the report analyses of the phase: its last session, or (pooled) every session, as
  // each participant's mean or (pool_sessions) each session as one observation.
  for (auto& a : study.analyses) {
    o << " " << a.kind << "(" << a.measure << " @ " << a.phase;
    if (a.pooled) o << (a.pool_sessions ? ", every session pooled" : ", participant means");
    if ((a.kind == "pairwise_t" || a.kind == "anova_oneway") && !a.welch) o << ", pooled variance";
    if (a.margin > 0) o << ", margin " << a.margin;
    o << ")";
  }
  if (study.analyses.empty())
    o << " none declared: the report analyses each measure in the last phase";
  o << "\n";
  return o.str();
}

}  // namespace palplab::protocols
