// `palplab validate STUDY.json`: checks the study and every prototype it names; exit 0 and a
// one-screen plan summary when valid, exit 2 with every problem (FILE:LINE:COL: $.path: what)
// otherwise.
#include <algorithm>
#include <charconv>
#include <iostream>
#include <memory>

#include "app/command.hpp"
#include "common/escape.hpp"
#include "common/format.hpp"
#include "common/input_error.hpp"
#include "protocols/plan.hpp"
#include "protocols/study.hpp"
#include "prototypes/factory.hpp"

namespace {

// A needle-insertion study: the scene each group meets in each phase, with its tools and whether
// the soft tissue is drawn see-through (the prototype's cue, overridden by the phase's switch).
// A prototype whose model has no finger and needle tools cannot run the task: exit 2 here
// rather than when its first session starts.
std::string needle_scenes(const palplab::protocols::Study& s, const std::string& file) {
  using namespace palplab;
  std::string out = "needle scenes (group / phase: prototype, model, tools, transparency):\n";
  for (const auto& g : s.groups)
    for (const auto& ph : s.phases) {
      std::string id = g.prototype;
      if (auto it = g.by_phase.find(ph.id); it != g.by_phase.end())
        id = it->second;
      else if (ph.prototype)
        id = *ph.prototype;
      const auto f = s.prototype_files.find(id);
      if (f == s.prototype_files.end()) continue;
      const engine::SceneConfig cfg = prototypes::load_prototype(f->second);
      if (cfg.model != "needle")
        throw InputError("prototype \"" + id + "\" (model \"" + cfg.model + "\", group \"" + g.id +
                             "\", phase \"" + ph.id +
                             "\") has no finger and needle tools; a needle_insertion task needs "
                             "model \"needle\"",
                         file);
      const bool transparent = ph.cues.transparency.value_or(cfg.cues.transparency);
      out += "  " + g.id + " / " + ph.id + ": " + id + ", model needle, tools finger+needle, " +
             (transparent ? "soft tissue transparent (tip and tip-to-target visible)"
                          : "opaque (tip not visible)") +
             (ph.cues.transparency ? " [phase switch]" : " [prototype]") + "\n";
    }
  return out;
}

palplab::app::CommandRegistration reg_validate{
    "validate", [](CLI::App& root, int* code) {
      auto* cmd =
          root.add_subcommand("validate", "Validate a study JSON file and summarise its plan");
      auto study = std::make_shared<std::string>();
      cmd->add_option("STUDY", *study, "Study file (JSON)")->required();
      cmd->callback([study, code] {
        using namespace palplab::protocols;
        Study s = load_study(*study, engine_prototype_inspector());
        Plan p = make_plan(s);
        std::cout << palplab::escape_controls(plan_summary(s, p));
        if (s.task.kind == "needle_insertion")
          std::cout << palplab::escape_controls(needle_scenes(s, *study));
        if (!s.hypotheses.empty()) {
          std::cout << "hypotheses (confirmatory, run first by `palplab report`):";
          for (const auto& h : s.hypotheses) {
            std::cout << " " << palplab::escape_controls(h.id) << "=" << h.test << "(" << h.measure
                      << " @ " << palplab::escape_controls(h.phase);
            for (const auto& [a, b] : h.pairs)
              std::cout << " " << palplab::escape_controls(a) << "-" << palplab::escape_controls(b);
            std::cout << ", alpha " << h.alpha << ", " << h.correction << ")";
          }
          std::cout << "\n";
        }
        std::cout << palplab::escape_controls("valid: " + *study) << "\n";
        // Valid but questionable: pooling repeated sessions as independent observations.
        for (std::size_t i = 0; i < s.analyses.size(); ++i)
          if (s.analyses[i].pooled && s.analyses[i].pool_sessions)
            std::cerr << palplab::escape_controls(*study) << ": warning: $.analyses[" << i
                      << "]: pool_sessions: true treats "
                      << "every session of a participant as an independent observation "
                      << "(pseudo-replication: df and p-values overstate the evidence); "
                      << "participant means (the default) or `palplab lmm` are valid\n";
        // Valid but without effect: the gap of a phase of one session (left behind when its
        // sessions were cut to one; review 2026-12-06, fourth).
        if (const auto js = nlohmann::json::parse(s.json_text, nullptr, false);
            js.is_object() && js.contains("phases") && js["phases"].is_array())
          for (std::size_t i = 0; i < s.phases.size() && i < js["phases"].size(); ++i)
            if (s.phases[i].sessions == 1 && js["phases"][i].is_object() &&
                js["phases"][i].contains("gap"))
              std::cerr << palplab::escape_controls(*study) << ": warning: $.phases[" << i
                        << "].gap: the phase has one session, so the gap between its sessions "
                           "has no effect (the next phase's start is set by its own \"start\")\n";
        // Valid but impossible: a feature that needs a longer touch than any session lasts is
        // never identified (every exploration time undefined).
        double longest = 0;
        for (const auto& ph : s.phases) longest = std::max(longest, ph.session_duration);
        if (s.task.kind == "palpation" && s.task.identify_dwell > longest)
          std::cerr << palplab::escape_controls(*study)
                    << ": warning: $.task.identify_dwell: " << s.task.identify_dwell
                    << " s of contact on the feature identifies it, longer than every session ("
                    << "the longest is " << longest
                    << " s): no session can identify the feature (feature_identified 0, "
                    << "exploration_time undefined in every session)\n";
        // Valid but questionable: a palpation must reach palpation_onset, and a press to the
        // target force (the feature's MPF) does not: `palpations` then counts only presses
        // beyond the target (review 2026-12-06).
        if (s.task.kind == "palpation") {
          auto it = s.task.thresholds.find(s.task.feature);
          if (it == s.task.thresholds.end()) it = s.task.thresholds.find("*");
          if (it != s.task.thresholds.end() && s.task.palpation_onset > it->second.mpf) {
            const auto task = nlohmann::json::parse(s.json_text, nullptr, false)
                                  .value("task", nlohmann::json::object());
            const bool set = task.is_object() && task.contains("palpation_onset");
            std::cerr << palplab::escape_controls(*study) << ": warning: "
                      << (set ? "$.task.palpation_onset: " : "$.task: the default palpation_onset ")
                      << palplab::format_shortest(s.task.palpation_onset)
                      << " N is above the feature's target force (MPF "
                      << palplab::format_shortest(it->second.mpf) << " N, SFT "
                      << palplab::format_shortest(it->second.sft)
                      << " N): a press to the target is not counted as a palpation (`palpations` "
                      << "counts only presses beyond it)\n";
          }
        }
        // Valid but easy to misread: without "*", the regions the study does not list keep each
        // prototype's own thresholds (and its sound at ST), which the database does not store
        // (review 2026-12-07).
        if (!s.task.thresholds.count("*")) {
          std::string own;
          for (const auto& [id, file] : s.prototype_files) {
            const palplab::engine::SceneConfig cfg = palplab::prototypes::load_prototype(file);
            const auto& regions = palplab::engine::mesh_region_names(cfg.mesh);
            if (std::all_of(regions.begin(), regions.end(),
                            [&](const std::string& r) { return s.task.thresholds.count(r) > 0; }))
              continue;  // every region listed: nothing is left to the prototype
            const auto it = cfg.thresholds.find("*");
            const palplab::engine::Thresholds t =
                it != cfg.thresholds.end() ? it->second : cfg.default_thresholds;
            char b[96];
            std::snprintf(b, sizeof b, "%s%s ST %g, MPF %g, SFT %g N", own.empty() ? "" : "; ",
                          id.c_str(), t.st, t.mpf, t.sft);
            own += b;
          }
          if (!own.empty())
            std::cerr << palplab::escape_controls(*study)
                      << ": warning: $.task.thresholds has no \"*\" entry: the regions it does not "
                         "list keep each prototype's own thresholds and sound at ST ("
                      << palplab::escape_controls(own)
                      << "), which the results database does not store; add \"*\" to give every "
                         "region the study's\n";
        }
        *code = 0;
      });
    }};
}  // namespace
