// Study loading and validation: every problem is collected (not just the first), each located at
// FILE:LINE:COL and JSON path, then thrown together as one palplab::InputError.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <tuple>

#include "common/format.hpp"
#include "common/input_error.hpp"
#include "common/json_check.hpp"
#include "common/json_locate.hpp"
#include "common/read_file.hpp"
#include "protocols/participants/params.hpp"
#include "protocols/plan.hpp"
#include "protocols/resolve.hpp"
#include "protocols/study.hpp"
#include "prototypes/factory.hpp"
#include "results/measure_kind.hpp"

namespace palplab::protocols {

using nlohmann::json;
using palplab::json::path_index;
using palplab::json::path_key;

// The lists below are views of results::kMeasureKinds, palplab's one table of its measures.
static std::vector<std::string> measure_names(bool (*keep)(const results::MeasureKind&,
                                                           std::string_view),
                                              std::string_view task) {
  std::vector<std::string> v;
  for (const results::MeasureKind& m : results::kMeasureKinds)
    if (keep(m, task)) v.emplace_back(m.name);
  return v;
}

const std::vector<std::string>& known_measures() {
  static const std::vector<std::string> m =
      measure_names([](const results::MeasureKind&, std::string_view) { return true; }, "");
  return m;
}

// "X is not in $.measures", saying where the list came from when the study declares none.
static std::string not_in_measures(const std::string& m, const json& root) {
  return "\"" + m + "\" is not in $.measures" +
         (root.contains("measures") ? std::string()
                                    : " (the task's default list: declare \"measures\" with it to "
                                      "analyse it)");
}

// Every measure a session of the task records, which $.measures may name: the defaults and the
// palpation task's two counts (stored and exported for every session, and refused here before
// although FORMATS documented them; review 2026-12-07).
static const std::vector<std::string>& task_measures(const std::string& task_kind) {
  auto of_task = [](const results::MeasureKind& m, std::string_view t) { return m.task == t; };
  static const std::vector<std::string> palpation = measure_names(of_task, "palpation");
  static const std::vector<std::string> needle = measure_names(of_task, "needle_insertion");
  return results::measure_task(task_kind) == "needle_insertion" ? needle : palpation;
}

const std::vector<std::string>& default_measures(const std::string& task_kind) {
  auto by_default = [](const results::MeasureKind& m, std::string_view t) {
    return m.task == t && m.by_default;
  };
  static const std::vector<std::string> palpation = measure_names(by_default, "palpation");
  static const std::vector<std::string> needle = measure_names(by_default, "needle_insertion");
  return results::measure_task(task_kind) == "needle_insertion" ? needle : palpation;
}

std::string measure_unit(const std::string& m) {
  const results::MeasureKind* k = results::find_measure_kind(m);
  return k ? std::string(k->unit) : std::string();
}

namespace {

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
  return s;
}

// Bounds on counts and times: beyond them a study is a typo (or an integer that would wrap).
constexpr long long kMaxDays = 3650;       // 10 years
constexpr long long kMaxSessions = 10000;  // per phase
// The longest haptic step a prototype may have (prototypes/factory.cpp, "haptic_step" <= 0.01 s):
// a session at least this long runs at least one step of any prototype (a shorter one would
// store a session of 0 steps).
constexpr double kMinSessionSeconds = 0.01;
// Task fields: forces are bounded as the thresholds are (prototypes::read_thresholds, 1e6 N); a
// dwell longer than a minute on the feature is no longer "touching it to identify it".
constexpr double kMaxIdentifyDwell = 60;  // s
constexpr long long kMaxGroupSize = 100000;

// The one validator shared with prototypes (common/json_check.hpp): same wording everywhere.
using Ctx = palplab::json::Checker;
using palplab::json::check_id;
using palplab::json::kind_name;

// {"seconds": x} | {"minutes": x} | {"hours": x} | {"days": n}: exactly one key, >= 0.
std::optional<Interval> parse_interval(Ctx& c, const json& j, const std::string& path) {
  if (!c.expect_object(j, path)) return std::nullopt;
  c.keys(j, path, {"seconds", "minutes", "hours", "days"});
  int n = 0;
  Interval iv;
  bool ok = true;
  for (const char* k : {"seconds", "minutes", "hours", "days"}) {
    if (!j.contains(k)) continue;
    ++n;
    if (std::string(k) == "days") {
      auto d = c.integer(j, path, k, true, "a whole number of days >= 0");
      if (!d) {
        ok = false;
        continue;
      }
      if (*d < 0 || *d > kMaxDays) {
        c.err(path_key(path, k), "expected a whole number of days in [0, " +
                                     std::to_string(kMaxDays) + "], got " + std::to_string(*d));
        ok = false;
        continue;
      }
      iv.calendar = true;
      iv.days = static_cast<int>(*d);
    } else {
      auto v = c.num(j, path, k, true, "a number >= 0");
      if (!v) {
        ok = false;
        continue;
      }
      double scale = std::string(k) == "minutes" ? 60.0 : std::string(k) == "hours" ? 3600.0 : 1.0;
      if (*v < 0 || *v * scale > kMaxDays * 86400.0) {
        c.err(path_key(path, k), std::string("expected a number >= 0 (") + k + ") of at most " +
                                     std::to_string(kMaxDays) + " days, got " + json(*v).dump());
        ok = false;
      }
      iv.seconds = *v * scale;
    }
  }
  if (n != 1) {
    c.err(path, "expected exactly one of \"seconds\", \"minutes\", \"hours\" or \"days\"");
    return std::nullopt;
  }
  if (!ok) return std::nullopt;
  return iv;
}

// The one reader of force limits, shared with prototype files (prototypes/factory.hpp).
void parse_limits(Ctx& c, const json& j, const std::string& path, engine::Thresholds& out) {
  if (!c.expect_object(j, path)) return;
  out = prototypes::read_thresholds(c, j, path);
}

// A non-empty id (see check_id).
std::optional<std::string> id_text(Ctx& c, const json& o, const std::string& path, const char* key,
                                   bool required) {
  auto v = c.nonempty_text(o, path, key, required);
  if (v) check_id(c, *v, path_key(path, key));
  return v;
}

// " N", " s", ...: nothing for a dimensionless ("1") parameter.
std::string unit_suffix(const std::string& unit) {
  return unit.empty() || unit == "1" ? std::string() : " " + unit;
}

void parse_params(Ctx& c, const json& j, const std::string& path,
                  const std::vector<participants::ParamSpec>& specs, json& out) {
  if (!c.expect_object(j, path)) return;
  std::vector<std::string> names;
  for (const auto& s : specs) names.push_back(s.name);
  c.keys(j, path, names);
  for (const auto& s : specs) {
    auto v = c.num(j, path, s.name, false);
    if (!v) continue;
    if (*v < s.min || *v > s.max) {
      c.err(path_key(path, s.name), std::string("expected a value in [") + json(s.min).dump() +
                                        ", " + json(s.max).dump() + "]" + unit_suffix(s.unit) +
                                        ", got " + json(*v).dump());
      continue;
    }
    out[s.name] = *v;
  }
}

}  // namespace

// $.phases[i].instructions: one text for every session of the phase or one per session
// (`run --human` shows it before the session).
static std::vector<std::string> parse_instructions(Ctx& c, const json& j, const std::string& P,
                                                   int sessions) {
  constexpr std::size_t kMaxChars = 4000;
  auto text = [&](const json& t, const std::string& tp) -> std::optional<std::string> {
    if (!t.is_string()) {
      c.err(tp, std::string("expected a text (string), got ") + kind_name(t));
      return std::nullopt;
    }
    std::string v = t.get<std::string>();
    if (v.find_first_not_of(" \t\r\n") == std::string::npos) {
      c.err(tp, "expected a non-empty text");
      return std::nullopt;
    }
    if (v.size() > kMaxChars) {
      c.err(tp, "expected at most " + std::to_string(kMaxChars) + " characters, got " +
                    std::to_string(v.size()));
      return std::nullopt;
    }
    return v;
  };
  std::vector<std::string> out;
  if (j.is_array()) {
    if (static_cast<long long>(j.size()) != sessions) {
      c.err(P, "expected one text per session (" + std::to_string(sessions) + "), got " +
                   std::to_string(j.size()) + " (or a single text for every session)");
      return {};
    }
    for (std::size_t k = 0; k < j.size(); ++k)
      if (auto v = text(j[k], path_index(P, k))) out.push_back(*v);
    return out.size() == j.size() ? out : std::vector<std::string>{};
  }
  if (auto v = text(j, P)) out.push_back(*v);
  return out;
}

Study parse_study(const std::string& text, const std::string& file,
                  const PrototypeInspector& inspect) {
  std::vector<Problem> repeated;  // reported with the file's other problems
  json root = palplab::json::parse_located(text, file, &repeated);
  Ctx c(file, text);
  c.add(repeated);
  Study s;
  s.file = file;
  s.json_text = text;
  const std::string R = "$";
  if (!c.expect_object(root, R)) c.throw_if_any();
  c.keys(root, R,
         {"palplab_study", "id", "title", "description", "seed", "task", "groups", "assignment",
          "phases", "roles", "measures", "participant_model", "analyses", "hypotheses",
          "prototype_dirs"});

  if (auto v = c.integer(root, R, "palplab_study", true, "the study format version, 1"))
    if (*v != kStudyFormatVersion)
      c.err("$.palplab_study", "unsupported study format version " + std::to_string(*v) +
                                   " (this palplab reads version 1)");
  if (auto v = id_text(c, root, R, "id", true)) s.id = *v;
  if (auto v = c.nonempty_text(root, R, "title", true)) s.title = *v;
  if (auto v = c.nonempty_text(root, R, "description", false)) s.description = *v;
  if (auto v = c.uint64(root, R, "seed", true, "an integer >= 0")) s.seed = *v;
  if (const json* v = c.member(root, R, "prototype_dirs", false, "an array of directories")) {
    if (!v->is_array())
      c.err("$.prototype_dirs", std::string("expected an array of strings, got ") + kind_name(*v));
    else
      for (std::size_t i = 0; i < v->size(); ++i) {
        const std::string DP = path_index("$.prototype_dirs", i);
        if (!(*v)[i].is_string()) {
          c.err(DP, "expected a directory path (string)");
          continue;
        }
        const std::string d = (*v)[i].get<std::string>();
        s.prototype_dirs.push_back(d);
        // Resolved as prototype_search_dirs does: relative to the study file's directory.
        namespace fs = std::filesystem;
        fs::path sdir = fs::path(file).parent_path();
        if (sdir.empty()) sdir = ".";
        const fs::path dp = fs::path(d).is_absolute() ? fs::path(d) : sdir / d;
        std::error_code ec;
        const auto st = fs::status(dp, ec);
        if (d.empty() || !fs::exists(st) || !fs::is_directory(st))
          c.err(DP, "expected an existing directory of prototype files, got \"" + d + "\" (" +
                        dp.lexically_normal().string() +
                        (d.empty()         ? ": an empty path)"
                         : !fs::exists(st) ? ": no such directory)"
                                           : ": not a directory)"));
      }
  }

  // ---- phases (before groups: groups may name phases)
  std::set<std::string> phase_ids;
  if (const json* ph = c.member(root, R, "phases", true, "an array of phases")) {
    if (!ph->is_array() || ph->empty()) {
      c.err("$.phases", std::string("expected a non-empty array of phases, got ") +
                            (ph->is_array() ? "an empty array" : kind_name(*ph)));
    } else {
      for (std::size_t i = 0; i < ph->size(); ++i) {
        std::string P = path_index("$.phases", i);
        const json& pj = (*ph)[i];
        Phase p;
        if (!c.expect_object(pj, P)) continue;
        c.keys(pj, P,
               {"id", "kind", "sessions", "session_duration", "start", "gap", "prototype", "cues",
                "instructed", "instructions"});
        if (auto v = id_text(c, pj, P, "id", true)) {
          p.id = *v;
          if (!phase_ids.insert(*v).second)
            c.err(path_key(P, "id"), "duplicate phase id \"" + *v + "\"");
        }
        if (auto v = c.one_of(pj, P, "kind", true,
                              {"pre_training", "training", "post_training", "other"}))
          p.kind = *v;
        if (auto v = c.integer(pj, P, "sessions", false, "an integer >= 1")) {
          if (*v < 1 || *v > kMaxSessions)
            c.err(path_key(P, "sessions"), "expected 1 to " + std::to_string(kMaxSessions) +
                                               " sessions, got " + std::to_string(*v));
          else
            p.sessions = static_cast<int>(*v);
        }
        if (auto v = c.num(pj, P, "session_duration", true, "a duration in s > 0")) {
          if (*v < kMinSessionSeconds || *v > kMaxSessionSeconds)
            c.err(path_key(P, "session_duration"),
                  "expected a duration in s of at least " + Ctx::fmt(kMinSessionSeconds) +
                      " (the longest haptic step a prototype may have: every session runs at least "
                      "one step) and at most " +
                      std::to_string(static_cast<int>(kMaxSessionSeconds)) + " s (24 h), got " +
                      json(*v).dump());
          else
            p.session_duration = *v;
        }
        if (const json* st = c.member(pj, P, "start", false, "")) {
          std::string SP = path_key(P, "start");
          if (c.expect_object(*st, SP)) {
            c.keys(*st, SP, {"day", "after_previous"});
            if (st->contains("day") == st->contains("after_previous")) {
              c.err(SP, "expected exactly one of \"day\" or \"after_previous\"");
            } else if (st->contains("day")) {
              if (auto d = c.integer(*st, SP, "day", true, "a day number >= 0")) {
                if (*d < 0 || *d > kMaxDays)
                  c.err(path_key(SP, "day"), "expected a day number in [0, " +
                                                 std::to_string(kMaxDays) + "], got " +
                                                 std::to_string(*d));
                else
                  p.start_day = static_cast<int>(*d);
              }
            } else {
              if (i == 0)
                c.err(path_key(SP, "after_previous"),
                      "the first phase has no previous phase; use {\"day\": 0}");
              if (auto iv =
                      parse_interval(c, (*st)["after_previous"], path_key(SP, "after_previous")))
                p.start_after = *iv;
            }
          }
        } else if (i == 0) {
          p.start_day = 0;
        }
        if (const json* g = c.member(pj, P, "gap", false, ""))
          if (auto iv = parse_interval(c, *g, path_key(P, "gap"))) p.gap = *iv;
        if (p.sessions > 1 && !pj.contains("gap"))
          c.err(P, "missing required key \"gap\" (the interval between this phase's " +
                       std::to_string(p.sessions) + " sessions)");
        if (auto v = c.nonempty_text(pj, P, "prototype", false)) p.prototype = *v;
        if (const json* cu = c.member(pj, P, "cues", false, "")) {
          std::string CP = path_key(P, "cues");
          if (c.expect_object(*cu, CP)) {
            c.keys(*cu, CP, {"haptic", "visual_deformation", "audio", "transparency"});
            p.cues.transparency = c.boolean(*cu, CP, "transparency");
            p.cues.haptic = c.boolean(*cu, CP, "haptic");
            p.cues.visual_deformation = c.boolean(*cu, CP, "visual_deformation");
            p.cues.audio = c.boolean(*cu, CP, "audio");
          }
        }
        if (auto v = c.boolean(pj, P, "instructed")) p.instructed = *v;
        if (const json* in = c.member(pj, P, "instructions", false, ""))
          p.instructions = parse_instructions(c, *in, path_key(P, "instructions"), p.sessions);
        s.phases.push_back(p);
      }
      std::vector<ScheduleProblem> sched_problems;
      if (c.problems().empty()) schedule(s.phases, &sched_problems);
      // At the key that sets the start: a phase's second session too close was said to be
      // at its "start" (review 2026-12-06, fourth: `"gap": {"days": 0}`).
      for (const auto& sp : sched_problems)
        c.err(path_key(path_index("$.phases", sp.phase), sp.key.c_str()), sp.message);
    }
  }

  // ---- groups and assignment
  if (auto v = c.one_of(root, R, "assignment", false, {"balanced_random", "explicit"}))
    s.assignment = *v;
  std::set<std::string> group_ids, participant_ids;
  // Groups as declared (entries with problems included): a test that compares groups needs two.
  std::size_t declared_groups = 0;
  if (const json* gs = c.member(root, R, "groups", true, "an array of groups")) {
    if (gs->is_array()) declared_groups = gs->size();
    if (!gs->is_array() || gs->empty()) {
      c.err("$.groups", std::string("expected a non-empty array of groups, got ") +
                            (gs->is_array() ? "an empty array" : kind_name(*gs)));
    } else {
      for (std::size_t i = 0; i < gs->size(); ++i) {
        std::string G = path_index("$.groups", i);
        const json& gj = (*gs)[i];
        if (!c.expect_object(gj, G)) continue;
        c.keys(gj, G, {"id", "prototype", "phase_prototypes", "size", "participants"});
        Group g;
        if (auto v = id_text(c, gj, G, "id", true)) {
          g.id = *v;
          if (!group_ids.insert(*v).second)
            c.err(path_key(G, "id"), "duplicate group id \"" + *v + "\"");
        }
        if (auto v = c.nonempty_text(gj, G, "prototype", true)) g.prototype = *v;
        if (const json* pp = c.member(gj, G, "phase_prototypes", false, "")) {
          std::string PP = path_key(G, "phase_prototypes");
          if (c.expect_object(*pp, PP))
            for (auto it = pp->begin(); it != pp->end(); ++it) {
              if (!phase_ids.count(it.key()))
                c.err(path_key(PP, it.key()), "unknown phase id \"" + it.key() + "\"", true);
              if (it.value().is_string() && !it.value().get<std::string>().empty())
                g.by_phase[it.key()] = it.value().get<std::string>();
              else
                c.err(path_key(PP, it.key()), "expected a prototype id (string)");
            }
        }
        bool explicit_list = s.assignment == "explicit";
        if (auto v = c.integer(gj, G, "size", !explicit_list, "an integer >= 1")) {
          if (*v < 1)
            c.err(path_key(G, "size"),
                  "empty group: expected at least 1 participant, got " + std::to_string(*v));
          else if (*v > kMaxGroupSize)
            c.err(path_key(G, "size"), "value " + std::to_string(*v) +
                                           " out of range: expected a group size in [1, " +
                                           std::to_string(kMaxGroupSize) + "]");
          else
            g.size = static_cast<int>(*v);
        }
        if (const json* pl = c.member(gj, G, "participants", explicit_list,
                                      "the participant ids of this group")) {
          std::string PL = path_key(G, "participants");
          if (!explicit_list) {
            c.err(PL, "participant lists need \"assignment\": \"explicit\"", true);
          } else if (!pl->is_array() || pl->empty()) {
            c.err(PL,
                  std::string("empty group: expected a non-empty array of participant ids, got ") +
                      (pl->is_array() ? "an empty array" : kind_name(*pl)));
          } else {
            for (std::size_t k = 0; k < pl->size(); ++k) {
              const json& e = (*pl)[k];
              if (!e.is_string() || e.get<std::string>().empty()) {
                c.err(path_index(PL, k), "expected a participant id (string)");
                continue;
              }
              check_id(c, e.get<std::string>(), path_index(PL, k));
              if (!participant_ids.insert(e.get<std::string>()).second)
                c.err(path_index(PL, k),
                      "participant \"" + e.get<std::string>() + "\" is listed more than once");
              g.participants.push_back(e.get<std::string>());
            }
            if (gj.contains("size") && g.size > 0 && g.size != static_cast<int>(pl->size()))
              c.err(path_key(G, "size"), "size " + std::to_string(g.size) + " does not match the " +
                                             std::to_string(pl->size()) + " listed participants");
            g.size = static_cast<int>(g.participants.size());
          }
        }
        s.groups.push_back(g);
      }
    }
  }

  // ---- task
  if (const json* t = c.member(root, R, "task", true, "the task: feature and thresholds")) {
    const std::string T = "$.task";
    if (c.expect_object(*t, T)) {
      c.keys(*t, T,
             {"kind", "scene", "feature", "thresholds", "accuracy_tolerance", "identify_dwell",
              "palpation_onset", "entry_hint", "target_depth_hint"});
      if (auto v = c.text(*t, T, "kind", false, {"palpation", "needle_insertion"}))
        s.task.kind = *v;
      const bool needle = s.task.kind == "needle_insertion";
      if (auto v = c.vec3(*t, T, "entry_hint", needle, -10, 10, "the briefed entry point (m)"))
        s.task.entry_hint = Eigen::Vector3d((*v)[0], (*v)[1], (*v)[2]);
      if (auto v = c.number(*t, T, "target_depth_hint", needle, 0, 1,
                            "the briefed depth of the target below the skin (m)", true))
        s.task.target_depth_hint = *v;
      if (!needle)
        for (const char* k : {"entry_hint", "target_depth_hint"})
          if (t->contains(k))
            c.err(path_key(T, k), std::string("\"") + k + "\" applies to needle_insertion tasks");
      if (auto v = c.nonempty_text(*t, T, "scene", false)) s.task.scene = *v;
      if (auto v = c.nonempty_text(*t, T, "feature", true)) s.task.feature = *v;
      // (0, max]: a huge value is a typo (1e308 N of onset: no contact is ever a palpation).
      if (auto v = c.number(*t, T, "accuracy_tolerance", false, 0, kMaxTaskForce,
                            "the accuracy tolerance (N)", true))
        s.task.accuracy_tolerance = *v;
      if (auto v = c.number(*t, T, "identify_dwell", false, 0, kMaxIdentifyDwell,
                            "the contact time on the feature that identifies it (s)", true))
        s.task.identify_dwell = *v;
      if (auto v = c.number(*t, T, "palpation_onset", false, 0, kMaxTaskForce,
                            "the force at which a contact counts as a palpation (N)", true))
        s.task.palpation_onset = *v;
      if (const json* th = c.member(*t, T, "thresholds", true, "region name -> {ST, MPF, SFT}")) {
        std::string TH = path_key(T, "thresholds");
        if (c.expect_object(*th, TH)) {
          if (th->empty()) c.err(TH, "expected at least one region (or \"*\") with ST, MPF, SFT");
          for (auto it = th->begin(); it != th->end(); ++it)
            parse_limits(c, it.value(), path_key(TH, it.key()), s.task.thresholds[it.key()]);
        }
      }
      if (!s.task.feature.empty() && !s.task.thresholds.count(s.task.feature) &&
          !s.task.thresholds.count("*") && t->contains("thresholds"))
        c.err("$.task.thresholds", "no thresholds for the feature \"" + s.task.feature +
                                       "\" (give it its own entry or a \"*\" entry)");
    }
  }

  // ---- roles
  int instructed_sessions = 0;
  for (const auto& p : s.phases)
    if (p.instructed) instructed_sessions += p.sessions;
  if (const json* ro = c.member(root, R, "roles", false, "")) {
    const std::string RO = "$.roles";
    if (c.expect_object(*ro, RO)) {
      c.keys(*ro, RO, {"trainee", "instructor"});
      if (const json* tr = c.member(*ro, RO, "trainee", false, "")) {
        std::string TR = "$.roles.trainee";
        if (c.expect_object(*tr, TR)) {
          c.keys(*tr, TR, {"kind"});
          c.one_of(*tr, TR, "kind", false, {"virtual"});
        }
      }
      if (const json* in = c.member(*ro, RO, "instructor", false, "")) {
        std::string IN = "$.roles.instructor";
        if (c.expect_object(*in, IN)) {
          InstructorRole role;
          c.keys(*in, IN, {"ids", "assignment", "parameters"});
          std::set<std::string> ids;
          if (const json* v = c.member(*in, IN, "ids", true, "the instructor ids")) {
            if (!v->is_array() || v->empty())
              c.err(path_key(IN, "ids"), "expected a non-empty array of instructor ids");
            else
              for (std::size_t k = 0; k < v->size(); ++k) {
                if (!(*v)[k].is_string()) {
                  c.err(path_index(path_key(IN, "ids"), k), "expected an instructor id (string)");
                  continue;
                }
                check_id(c, (*v)[k].get<std::string>(), path_index(path_key(IN, "ids"), k));
                if (!ids.insert((*v)[k].get<std::string>()).second)
                  c.err(path_index(path_key(IN, "ids"), k), "duplicate instructor id");
                role.ids.push_back((*v)[k].get<std::string>());
              }
          }
          if (const json* a = c.member(*in, IN, "assignment", true,
                                       "group id -> instructor per instructed session")) {
            std::string A = path_key(IN, "assignment");
            if (c.expect_object(*a, A)) {
              for (auto it = a->begin(); it != a->end(); ++it) {
                std::string AG = path_key(A, it.key());
                if (!group_ids.count(it.key()))
                  c.err(AG, "unknown group id \"" + it.key() + "\"", true);
                if (!it.value().is_array()) {
                  c.err(AG, "expected an array of instructor ids, one per instructed session");
                  continue;
                }
                if (static_cast<int>(it.value().size()) != instructed_sessions)
                  c.err(AG, "expected " + std::to_string(instructed_sessions) +
                                " instructor ids (one per instructed session), got " +
                                std::to_string(it.value().size()));
                std::vector<std::string> list;
                for (std::size_t k = 0; k < it.value().size(); ++k) {
                  const json& e = it.value()[k];
                  if (!e.is_string() || !ids.count(e.get<std::string>()))
                    c.err(path_index(AG, k),
                          "expected one of the instructor ids: " + join(role.ids));
                  else
                    list.push_back(e.get<std::string>());
                }
                role.assignment[it.key()] = list;
              }
              for (const auto& g : group_ids)
                if (!a->contains(g)) c.err(A, "missing the instructor list of group \"" + g + "\"");
            }
          }
          if (const json* pj = c.member(*in, IN, "parameters", false, ""))
            parse_params(c, *pj, path_key(IN, "parameters"), participants::instructor_param_specs(),
                         role.parameters);
          s.instructor = role;
        }
      }
    }
  }
  if (instructed_sessions > 0 && !s.instructor)
    c.err("$.roles", "phases are \"instructed\" but no roles.instructor is defined");
  if (instructed_sessions == 0 && s.instructor)
    c.err("$.roles.instructor", "an instructor is defined but no phase is \"instructed\"", true);

  // ---- measures
  if (const json* m = c.member(root, R, "measures", false, "")) {
    if (!m->is_array() || m->empty()) {
      c.err("$.measures", "expected a non-empty array of measure names: " + join(known_measures()));
    } else {
      // The measures of the study's task: a needle measure in a palpation study (or the reverse)
      // was accepted, and the task's own measures were recorded and reported instead.
      const auto& tm = task_measures(s.task.kind);
      for (std::size_t i = 0; i < m->size(); ++i) {
        const json& e = (*m)[i];
        auto& km = known_measures();
        if (!e.is_string() || std::find(km.begin(), km.end(), e.get<std::string>()) == km.end()) {
          c.err(path_index("$.measures", i),
                "expected a measure name of the " + s.task.kind + " task, one of: " + join(tm));
          continue;
        }
        if (std::find(tm.begin(), tm.end(), e.get<std::string>()) == tm.end()) {
          c.err(path_index("$.measures", i),
                "\"" + e.get<std::string>() + "\" is not a measure of this study's " + s.task.kind +
                    " task (its measures: " + join(tm) + ")");
          continue;
        }
        const std::string name = e.get<std::string>();
        if (auto it = std::find(s.measures.begin(), s.measures.end(), name);
            it != s.measures.end()) {
          std::size_t first = 0;  // its index in the JSON array (bad entries are not stored)
          while ((*m)[first] != e) ++first;
          c.err(path_index("$.measures", i), "duplicate measure \"" + name + "\" (already " +
                                                 path_index("$.measures", first) + ")");
          continue;
        }
        s.measures.push_back(name);
      }
    }
  } else {
    s.measures = default_measures(s.task.kind);
  }

  // ---- participant model
  if (const json* pm = c.member(root, R, "participant_model", false, "")) {
    const std::string PM = "$.participant_model";
    if (c.expect_object(*pm, PM)) {
      c.keys(*pm, PM, {"model", "parameters"});
      if (auto v = c.one_of(*pm, PM, "model", false, {"pmm1"})) s.participant_model = *v;
      if (const json* pj = c.member(*pm, PM, "parameters", false, ""))
        parse_params(c, *pj, path_key(PM, "parameters"), participants::trainee_param_specs(),
                     s.participant_parameters);
    }
  }

  // ---- analyses
  if (const json* an = c.member(root, R, "analyses", false, "")) {
    if (!an->is_array()) {
      c.err("$.analyses", std::string("expected an array, got ") + kind_name(*an));
    } else {
      std::vector<std::size_t> source;  // s.analyses[k] is $.analyses[source[k]]
      for (std::size_t i = 0; i < an->size(); ++i) {
        std::string A = path_index("$.analyses", i);
        const json& aj = (*an)[i];
        if (!c.expect_object(aj, A)) continue;
        c.keys(aj, A, {"kind", "measure", "phase", "welch", "pooled", "pool_sessions", "margin"});
        Analysis a;
        if (auto v = c.one_of(aj, A, "kind", true, {"anova_oneway", "pairwise_t", "descriptives"}))
          a.kind = *v;
        const bool compares = a.kind == "anova_oneway" || a.kind == "pairwise_t";
        if (auto v = c.one_of(aj, A, "measure", true, known_measures())) {
          a.measure = *v;
          if (std::find(s.measures.begin(), s.measures.end(), *v) == s.measures.end())
            c.err(path_key(A, "measure"), not_in_measures(*v, root));
        }
        if (auto v = c.nonempty_text(aj, A, "phase", true)) {
          a.phase = *v;
          if (!phase_ids.empty() && !phase_ids.count(*v))
            c.err(path_key(A, "phase"), "unknown phase id \"" + *v + "\"");
        }
        if (auto v = c.boolean(aj, A, "welch")) a.welch = *v;
        if (auto v = c.boolean(aj, A, "pooled")) a.pooled = *v;
        if (auto v = c.boolean(aj, A, "pool_sessions")) {
          a.pool_sessions = *v;
          if (*v && !a.pooled)
            c.err(path_key(A, "pool_sessions"),
                  "pool_sessions: true needs \"pooled\": true (it says how pooled sessions are "
                  "analysed)");
        }
        if (auto v = c.num(aj, A, "margin", false,
                           "a positive number (equivalence margin, "
                           "in the measure's unit)")) {
          if (*v <= 0)
            c.err(path_key(A, "margin"),
                  "expected a positive number (equivalence margin, in the measure's unit), got " +
                      json(*v).dump());
          else
            a.margin = *v;
        }
        // An ANOVA compares groups and a pair needs two: with one group the test is never
        // defined (report, power and run would carry an analysis that cannot be computed).
        if (compares && declared_groups == 1)
          c.err(A, "analysis \"" + a.kind + "\"" + (a.measure.empty() ? "" : " of " + a.measure) +
                       (a.phase.empty() ? "" : " in phase " + a.phase) +
                       " needs at least 2 groups to compare; the study has 1 (add a group, make "
                       "it \"descriptives\" or remove the analysis)");
        // The same analysis twice (a copy-paste) would be run, reported and counted in power
        // twice (review 2026-12-06: it passed without a word).
        for (std::size_t k = 0; k < s.analyses.size(); ++k) {
          const Analysis& b = s.analyses[k];
          if (!a.kind.empty() && !a.measure.empty() && !a.phase.empty() && a.kind == b.kind &&
              a.measure == b.measure && a.phase == b.phase && a.welch == b.welch &&
              a.pooled == b.pooled && a.pool_sessions == b.pool_sessions && a.margin == b.margin) {
            c.err(A, "the same analysis as " + path_index("$.analyses", source[k]) + " (\"" +
                         a.kind + "\" of " + a.measure + " in phase " + a.phase +
                         ", with the same options): remove one");
            break;
          }
          // The report makes one section per measure, phase and pooling, holding every kind
          // declared for it: welch, pool_sessions and margin are that section's options. Two
          // entries that set one differently had the last one win silently (a declared
          // Student t and its margin vanished from the report: review 2026-12-07).
          if (a.measure.empty() || a.measure != b.measure || a.phase != b.phase ||
              a.pooled != b.pooled)
            continue;
          const json& bj = (*an)[source[k]];
          // Both make pairwise t-tests (an ANOVA's section has them too), Welch's by default.
          const auto pairs = [](const Analysis& x) {
            return x.kind == "pairwise_t" || x.kind == "anova_oneway";
          };
          const bool both_t = pairs(a) && pairs(b);
          // What an entry says of a key, its default when it says nothing (welch, pool_sessions).
          const auto said = [](const json& e, const char* key, const Analysis& x) {
            const bool value = key == std::string("welch") ? x.welch : x.pool_sessions;
            return e.contains(key) ? e[key].dump() : json(value).dump() + " (the default)";
          };
          // pool_sessions by its value, default included: an entry left at the default beside
          // one that pools every session was shown by validate as participant means while the
          // report pooled the whole section (review 2026-12-07).
          for (const char* key : {"welch", "pool_sessions", "margin"})
            if ((aj.contains(key) && bj.contains(key) && aj[key] != bj[key]) ||
                (both_t && key == std::string("welch") && a.welch != b.welch) ||
                (key == std::string("pool_sessions") && a.pool_sessions != b.pool_sessions))
              c.err(path_key(A, key),
                    said(aj, key, a) + " here but " + said(bj, key, b) + " in " +
                        path_index("$.analyses", source[k]) + ", an analysis of the same " +
                        "measure and phase" + (a.pooled ? " (pooled)" : "") +
                        ": the report makes one section of them, and " + key +
                        " is that section's option (declare it once, or give both the same)");
        }
        s.analyses.push_back(a);
        source.push_back(i);
      }
      // A margin is the equivalence test's, which the report runs in a section with an ANOVA or
      // pairwise t-tests: on a section of descriptives alone it did nothing (review 2026-12-07).
      for (std::size_t k = 0; k < s.analyses.size(); ++k) {
        const Analysis& a = s.analyses[k];
        if (!(a.margin > 0)) continue;
        const bool tested = std::any_of(s.analyses.begin(), s.analyses.end(), [&](const auto& b) {
          return b.measure == a.measure && b.phase == a.phase && b.pooled == a.pooled &&
                 (b.kind == "anova_oneway" || b.kind == "pairwise_t");
        });
        if (!tested)
          c.err(path_key(path_index("$.analyses", source[k]), "margin"),
                "a margin is that of the equivalence test (TOST) the report runs beside an "
                "anova_oneway or pairwise_t of the same measure and phase; this study has none "
                "of " +
                    a.measure + " in phase " + a.phase + " (declare one, or remove the margin)");
      }
    }
  }

  // ---- size of the plan: validate builds it, so it must stay bounded (a typo such as a group
  // of 100000 with 10000 sessions would otherwise take all memory instead of failing).
  {
    long long participants = 0, sessions = 0;
    for (const auto& g : s.groups) participants += g.size;
    for (const auto& p : s.phases) sessions += p.sessions;
    if (participants * sessions > kMaxPlannedSessions)
      c.err("$.groups", "the study plans " + std::to_string(participants) + " participants x " +
                            std::to_string(sessions) +
                            " sessions = " + std::to_string(participants * sessions) +
                            " sessions; palplab runs at most " +
                            std::to_string(kMaxPlannedSessions) + " per study");
  }

  // ---- hypotheses (declared, confirmatory analyses)
  if (const json* hy = c.member(root, R, "hypotheses", false, "")) {
    if (!hy->is_array()) {
      c.err("$.hypotheses", std::string("expected an array, got ") + kind_name(*hy));
    } else {
      std::set<std::string> ids;
      for (std::size_t i = 0; i < hy->size(); ++i) {
        std::string H = path_index("$.hypotheses", i);
        const json& hj = (*hy)[i];
        if (!c.expect_object(hj, H)) continue;
        c.keys(hj, H,
               {"id", "statement", "measure", "phase", "test", "pairs", "margins", "alpha",
                "correction", "pooled"});
        Hypothesis h;
        if (auto v = id_text(c, hj, H, "id", true)) {
          h.id = *v;
          if (!ids.insert(*v).second)
            c.err(path_key(H, "id"), "duplicate hypothesis id \"" + *v + "\"");
        }
        if (auto v = c.text(hj, H, "statement", false)) h.statement = *v;
        if (auto v = c.one_of(hj, H, "measure", true, known_measures())) {
          h.measure = *v;
          if (std::find(s.measures.begin(), s.measures.end(), *v) == s.measures.end())
            c.err(path_key(H, "measure"), not_in_measures(*v, root));
        }
        if (auto v = c.nonempty_text(hj, H, "phase", true)) {
          h.phase = *v;
          if (!phase_ids.empty() && !phase_ids.count(*v))
            c.err(path_key(H, "phase"), "unknown phase id \"" + *v + "\"");
        }
        if (auto v =
                c.one_of(hj, H, "test", true, {"anova_oneway", "welch_t", "student_t", "tost"}))
          h.test = *v;
        if (const json* pj = c.member(hj, H, "pairs", false, "")) {
          const std::string PP = path_key(H, "pairs");
          if (h.test == "anova_oneway") {
            c.err(PP, "an anova_oneway hypothesis is about all groups; pairs apply to t and tost");
          } else if (!pj->is_array() || pj->empty()) {
            c.err(PP, "expected a non-empty array of [group, group] pairs, got " +
                          std::string(kind_name(*pj)));
          } else {
            std::vector<std::size_t> at;  // the JSON index of each pair kept in h.pairs
            for (std::size_t k = 0; k < pj->size(); ++k) {
              const json& pr = (*pj)[k];
              const std::string PK = path_index(PP, k);
              if (!pr.is_array() || pr.size() != 2 || !pr[0].is_string() || !pr[1].is_string()) {
                c.err(PK, "expected a pair of group ids [\"B\", \"C\"], got " + pr.dump());
                continue;
              }
              const std::string a = pr[0], b = pr[1];
              bool ok = true;
              for (const auto& g : {a, b})
                if (!group_ids.count(g)) {
                  c.err(PK, "unknown group id \"" + g + "\"; expected one of: " +
                                join(std::vector<std::string>(group_ids.begin(), group_ids.end())));
                  ok = false;
                }
              // The same comparison twice (either order) would be counted twice by the Holm
              // correction over the pairs.
              const auto same = std::find_if(h.pairs.begin(), h.pairs.end(), [&](const auto& q) {
                return (q.first == a && q.second == b) || (q.first == b && q.second == a);
              });
              if (ok && a == b)
                c.err(PK, "a pair needs two different groups, got \"" + a + "\" twice");
              else if (ok && same != h.pairs.end())
                c.err(PK, "the pair [\"" + a + "\", \"" + b + "\"] repeats the comparison " +
                              path_index(PP, at[static_cast<std::size_t>(same - h.pairs.begin())]) +
                              " (the Holm correction over the pairs would count it twice)");
              else if (ok)
                h.pairs.push_back({a, b}), at.push_back(k);
            }
          }
        }
        if (const json* mj = c.member(hj, H, "margins", false, "")) {
          const std::string PM = path_key(H, "margins");
          if (mj->is_number() && std::isfinite(mj->get<double>()) && mj->get<double>() > 0) {
            h.margins = std::make_pair(-mj->get<double>(), mj->get<double>());
          } else if (mj->is_array() && mj->size() == 2 && (*mj)[0].is_number() &&
                     (*mj)[1].is_number() && (*mj)[0].get<double>() < 0 &&
                     (*mj)[1].get<double>() > 0) {
            h.margins = std::make_pair((*mj)[0].get<double>(), (*mj)[1].get<double>());
          } else {
            c.err(PM,
                  "expected a positive number m (margins ±m) or [low < 0, high > 0] in the "
                  "measure's unit, got " +
                      mj->dump());
          }
          if (h.test != "tost" && h.margins)
            c.err(PM, "margins apply to a tost hypothesis only (test is \"" + h.test + "\")");
        } else if (h.test == "tost") {
          c.err(H,
                "missing required key \"margins\" (a tost hypothesis needs its equivalence "
                "margins)");
        }
        if (auto v = c.num(hj, H, "alpha", false, "a number in (0, 0.5]")) {
          if (*v <= 0 || *v > 0.5)
            c.err(path_key(H, "alpha"), "expected a number in (0, 0.5], got " + json(*v).dump());
          else
            h.alpha = *v;
        }
        if (auto v = c.one_of(hj, H, "correction", false, {"holm", "bonferroni", "none"}))
          h.correction = *v;
        if (auto v = c.boolean(hj, H, "pooled")) h.pooled = *v;
        // Every hypothesis test compares groups (declared pairs are checked above).
        if (declared_groups == 1 && !h.test.empty() && !hj.contains("pairs"))
          c.err(H, "hypothesis \"" + h.id + "\" (" + h.test +
                       ") compares groups; the study has 1 group (add a group or remove the "
                       "hypothesis)");
        s.hypotheses.push_back(h);
      }
    }
  }

  // ---- prototypes: resolve every id, inspect each file once, check region names
  auto dirs = prototype_search_dirs(file, s.prototype_dirs);
  std::vector<std::pair<std::string, std::string>> uses;  // id, path where it is named
  for (std::size_t i = 0; i < s.groups.size(); ++i) {
    std::string G = path_index("$.groups", i);
    if (!s.groups[i].prototype.empty())
      uses.push_back({s.groups[i].prototype, path_key(G, "prototype")});
    for (auto& [ph, id] : s.groups[i].by_phase)
      uses.push_back({id, path_key(path_key(G, "phase_prototypes"), ph)});
  }
  for (std::size_t i = 0; i < s.phases.size(); ++i)
    if (s.phases[i].prototype)
      uses.push_back({*s.phases[i].prototype, path_key(path_index("$.phases", i), "prototype")});
  std::map<std::string, PrototypeInfo> infos;
  std::set<std::string> failed;
  for (auto& [id, path] : uses) {
    if (infos.count(id) || failed.count(id)) continue;
    std::string f = resolve_prototype(id, dirs, file);
    if (f.empty()) {
      if (id.empty() || id.find('/') != std::string::npos || id[0] == '.' ||
          (id.size() > 5 && id.compare(id.size() - 5, 5, ".json") == 0))
        c.err(path,
              "prototype \"" + id +
                  "\" is not a prototype id (a file name without \".json\", no \"/\", not "
                  "starting with \".\"): put the prototype's directory in \"prototype_dirs\"");
      else {
        // A near miss among the prototypes the directories hold ("Bstif" for Bstiff).
        std::vector<std::string> held;
        std::error_code ec;
        for (const auto& dir : dirs)
          for (const auto& e : std::filesystem::directory_iterator(dir, ec))
            if (e.path().extension() == ".json") held.push_back(e.path().stem().string());
        const bool self = std::filesystem::path(file).filename() == id + ".json";
        c.err(path, "unresolved prototype \"" + id + "\": no " + id + ".json in " + join(dirs) +
                        (self ? " (besides this study file itself, which is not a prototype)"
                              : palplab::json::did_you_mean(id, held)));
      }
      failed.insert(id);
      continue;
    }
    try {
      std::string text;               // exists and parses, located errors otherwise
      std::vector<Problem> repeated;  // the inspector reports them with the file's others
      palplab::json::parse_file_located(f, &text, &repeated);
      if (!inspect && !repeated.empty()) throw InputError(std::move(repeated));
      const PrototypeInfo info = inspect ? inspect(f) : PrototypeInfo{};
      // A study names a prototype by its file (ID.json); the file's own "id" must agree, or
      // the database would store one name while `probe`, `scene` and the report show another.
      if (!info.id.empty() && info.id != id) {
        c.problems().push_back({palplab::json::JsonLocator(text).locate(f, "$.id"),
                                "expected \"" + id + "\" (the prototype's file name, " + id +
                                    ".json, is its id), got \"" + info.id +
                                    "\": rename the file or the id"});
        c.err(path, "prototype \"" + id + "\" (" + f + ") has the id \"" + info.id + "\"");
        failed.insert(id);
        continue;
      }
      infos[id] = info;
      s.prototype_files[id] = f;
    } catch (const InputError& e) {
      for (const auto& p : e.problems()) c.problems().push_back(p);
      c.err(path, "prototype \"" + id + "\" (" + f +
                      ") is not valid (see the problems reported in that file)");
      failed.insert(id);
    }
  }
  // Region names must exist in every prototype the study uses (a session may run on any);
  // one problem per name, listing the prototypes that lack it.
  if (inspect && !infos.empty()) {
    auto lacking = [&](const std::string& r) {
      std::vector<std::string> ids;
      for (auto& [id, info] : infos)
        if (std::find(info.region_names.begin(), info.region_names.end(), r) ==
            info.region_names.end())
          ids.push_back(id);
      return ids;
    };
    auto regions = [&](const std::vector<std::string>& ids) {
      return join(infos.at(ids.front()).region_names);
    };
    if (!s.task.feature.empty())
      if (auto ids = lacking(s.task.feature); !ids.empty())
        c.err("$.task.feature", "region \"" + s.task.feature +
                                    "\" is not a region of prototype(s) " + join(ids) +
                                    " (regions: " + regions(ids) + ")");
    // A palpation feature is found by touch: a tissue inside the body (a tet mesh's inner region)
    // cannot be one (review 2026-12-06, second: `validate` passed, `run` stopped at its first
    // session with a database made). A needle's target is such a tissue.
    if (!s.task.feature.empty() && s.task.kind != "needle_insertion") {
      std::vector<std::string> ids;
      for (auto& [id, info] : infos)
        if (std::find(info.inner_regions.begin(), info.inner_regions.end(), s.task.feature) !=
            info.inner_regions.end())
          ids.push_back(id);
      if (!ids.empty())
        c.err("$.task.feature", "region \"" + s.task.feature + "\" of prototype(s) " + join(ids) +
                                    " is a tissue inside the body (no vertex on its surface): a "
                                    "palpation task's feature must be touchable");
    }
    for (auto& [r, lim] : s.task.thresholds)
      if (r != "*")
        if (auto ids = lacking(r); !ids.empty())
          c.err(path_key("$.task.thresholds", r),
                "region \"" + r + "\" is not a region of prototype(s) " + join(ids) +
                    " (regions: " + regions(ids) + ")",
                true);
    for (auto& [id, info] : infos)
      if (!s.task.scene.empty() && !info.scene.empty() && info.scene != s.task.scene)
        c.err("$.task.scene", "prototype \"" + id + "\" simulates scene \"" + info.scene +
                                  "\", not \"" + s.task.scene + "\"");
  }
  // A session runs a whole number of its prototype's haptic steps, and the plan places the next
  // session at start + session_duration: a duration between two step counts (0.0105 s at 1 kHz)
  // ran 11 steps and the next session started 0.5 ms before this one ended (review 2026-12-07).
  // Whole up to the rounding of the decimals (relative 1e-12: 1000.0005 s at 1 kHz is not).
  auto whole_steps = [](double duration, double dt) {
    const double steps = duration / dt;
    return std::abs(steps - std::round(steps)) <= 1e-12 * std::max(1.0, steps);
  };
  // The fewest decimals that give x back within `tol` (relative): 0.009, not
  // 0.009000000000000001; 1000, not 1e+03.
  for (std::size_t pi = 0; pi < s.phases.size(); ++pi) {
    const Phase& ph = s.phases[pi];
    if (!(ph.session_duration > 0)) continue;
    std::set<std::string> ids;  // the prototypes a session of this phase may run on
    for (const Group& g : s.groups) {
      if (auto it = g.by_phase.find(ph.id); it != g.by_phase.end())
        ids.insert(it->second);
      else if (ph.prototype)
        ids.insert(*ph.prototype);
      else if (!g.prototype.empty())
        ids.insert(g.prototype);
    }
    std::vector<std::pair<std::string, double>> steps;  // (id, dt) of every prototype known
    for (const std::string& id : ids)
      if (auto it = infos.find(id); it != infos.end() && it->second.dt > 0)
        steps.push_back({id, it->second.dt});
    const auto bad = std::find_if(steps.begin(), steps.end(), [&](const auto& x) {
      return !whole_steps(ph.session_duration, x.second);
    });
    if (bad == steps.end()) continue;
    // The nearest durations below and above that are whole numbers of every prototype's steps
    // (walking the largest step's multiples; none said if none is near).
    double largest = 0;
    for (const auto& x : steps) largest = std::max(largest, x.second);
    auto fits_all = [&](double t) {
      if (t < kMinSessionSeconds - 1e-12 || t > kMaxSessionSeconds) return false;
      for (const auto& x : steps)
        if (!whole_steps(t, x.second)) return false;
      return true;
    };
    std::vector<std::string> would_do;
    const double m = std::floor(ph.session_duration / largest);
    for (double k = m; k >= 1 && k > m - 100000; --k)
      if (fits_all(k * largest)) {
        would_do.push_back(format_fixed_within(k * largest));
        break;
      }
    for (double k = m + 1; k < m + 100001; ++k)
      if (fits_all(k * largest)) {
        would_do.push_back(format_fixed_within(k * largest));
        break;
      }
    std::string hint;
    if (!would_do.empty())
      hint = " (" + would_do.front() + (would_do.size() > 1 ? " or " + would_do.back() : "") +
             " s would do" + (steps.size() > 1 ? " on every prototype of the phase" : "") + ")";
    c.err(path_key(path_index("$.phases", pi), "session_duration"),
          "expected a whole number of prototype \"" + bad->first + "\"'s haptic steps (" +
              format_fixed_within(bad->second) + " s each), got " +
              format_fixed_within(ph.session_duration) + " s = " +
              format_fixed_within(ph.session_duration / bad->second,
                                  1e-4 / std::max(1.0, ph.session_duration / bad->second)) +
              " steps" + hint);
  }

  c.throw_if_any();  // every problem, in file order
  return s;
}

Study load_study(const std::string& path, const PrototypeInspector& inspect) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError("is a directory (expected a study file, JSON)", path);
  // Bounded like every JSON input: /dev/zero or a pipe that never ends stops at the limit.
  return parse_study(read_file_bounded(path, palplab::json::kMaxJsonFileBytes, "JSON study file"),
                     path, inspect);
}

}  // namespace palplab::protocols
