// `palplab bench sleeping`: integrating only what the scene needs (sleeping of nodes at rest,
// a local integration scope) against integrating every node every step, on prototype C with the
// same fixed presses (ramp at 2 cm/s to 6 mm — 4 mm in --quick — then hold; the trajectory does
// not depend on the force, so every variant sees the same device positions at the same times).
// Per variant: time per haptic step (one repetition = one press, its sample = the mean step
// time), the speed-up over the full integration measured in the same run, and the error it costs
// against the full integration of the same model: the largest force difference relative to
// the peak force, and the largest difference of the visible deformation (m). Per-step
// median / p99 / max are over every step of the timed presses; CG iterations are those of the
// first press (cg_iterations_mean per integrator step). (The error
// against the continuum — the FEM reference — is the frontier section's.)
#include <algorithm>
#include <nlohmann/json.hpp>

#include "app/bench.hpp"
#include "app/bench_scene.hpp"
#include "engine/haptics/clock.hpp"
#include "prototypes/factory.hpp"

namespace {
using namespace palplab;
using palplab::app::BenchOptions;
using palplab::app::BenchResult;

struct SleepingVariant {
  std::string name, what;
  double radius;
  int cap;  // 0 = no cap
  bool sleep;
  double x_tol;
  std::string exterior;  // of the scope: "held" or "linear"
};

std::vector<BenchResult> run_sleeping(const BenchOptions& o) {
  // "held": the exterior of the scope stays at rest (prototype C before); "linear": it follows
  // the whole model's linear static response to the contact force (prototype C now).
  const std::vector<SleepingVariant> variants = {
      {"full", "every node every step (reference)", 0, 0, false, 0, "held"},
      {"sleeping", "sleeping only (10 um)", 0, 0, true, 1e-5, "held"},
      {"scope3cm_held", "scope 3 cm + sleeping, exterior held at rest", 0.03, 0, true, 1e-5,
       "held"},
      {"scope5cm_held", "scope 5 cm + sleeping, exterior held at rest", 0.05, 0, true, 1e-5,
       "held"},
      {"scope3cm_linear", "scope 3 cm, linear exterior (prototype C)", 0.03, 0, true, 1e-5,
       "linear"},
      {"scope2cm_linear", "scope 2 cm, linear exterior", 0.02, 0, true, 1e-5, "linear"},
      {"scope3cm_cap64", "scope 3 cm, <= 64 nodes + sleeping (a cap keeps the exterior held)", 0.03,
       64, true, 1e-5, "held"}};
  const std::vector<std::string> regions =
      o.quick ? std::vector<std::string>{"ovary_left"}
              : std::vector<std::string>{"ovary_left", "horn_right", "body"};
  const double depth = o.quick ? 0.004 : 0.006;
  const int steps = o.quick ? 400 : 600;
  const int reps = 5;
  std::vector<engine::Scene> scenes;
  for (const SleepingVariant& v : variants)
    scenes.push_back(prototypes::build_scene(
        app::prototype_variant(o, "C", "sleep_" + v.name, [&](nlohmann::json& j) {
          auto& m = j["model"];
          m["scope_radius"] = v.radius;
          if (v.cap > 0) m["scope_max_nodes"] = v.cap;
          m["sleeping"]["enabled"] = v.sleep;
          if (v.sleep) m["sleeping"]["position_tolerance"] = v.x_tol;
          m["scope_exterior"] = v.exterior;
        })));
  std::vector<BenchResult> out;
  for (const std::string& region : regions) {
    std::vector<std::vector<double>> t(variants.size()), steps_all(variants.size());
    std::vector<app::PressTrace> first(variants.size());
    std::vector<double> cg_mean(variants.size()), cg_max(variants.size());
    for (int rep = 0; rep <= reps; ++rep)
      for (size_t k = 0; k < variants.size(); ++k) {
        scenes[k].reset();
        app::PressTrace p = app::fixed_press(scenes[k], region, depth, steps);
        double sum = 0;
        for (double s : p.step_s) sum += s;
        if (rep == 0) {
          const auto info = nlohmann::json::parse(scenes[k].stats().model_info);
          cg_mean[k] = info["mass_spring"]["cg_iterations_mean"].get<double>();
          cg_max[k] = info["mass_spring"]["cg_iterations_max"].get<double>();
          first[k] = std::move(p);
        } else {
          t[k].push_back(sum / steps);
          steps_all[k].insert(steps_all[k].end(), p.step_s.begin(), p.step_s.end());
        }
      }
    const double full = engine::median(t[0]);
    for (size_t k = 0; k < variants.size(); ++k) {
      double cold = 0;
      for (double s : first[k].step_s) cold += s;
      BenchResult r = app::result_from_samples(
          region + "_" + variants[k].name,
          "prototype C, " + region + " press: " + variants[k].what + " (s per haptic step)", t[k],
          cold / steps);
      double dd = 0;
      for (size_t i = 0; i < first[k].deformation.size(); ++i)
        dd = std::max(dd, std::abs(first[k].deformation[i] - first[0].deformation[i]));
      r.metrics = {
          {"speedup", full / r.median_s},
          {"awake_max", static_cast<double>(first[k].awake_max)},
          {"peak_force_N", *std::max_element(first[k].force.begin(), first[k].force.end())},
          {"force_rel_err", app::max_rel_diff(first[k].force, first[0].force)},
          {"deformation_err_m", dd},
          {"cg_iterations_mean", cg_mean[k]},
          {"cg_iterations_max", cg_max[k]},
          // Per haptic step over the timed repetitions (the cold first press is left out).
          {"median_step_s", engine::median(steps_all[k])},
          {"p99_step_s", engine::quantile(steps_all[k], 0.99)},
          {"max_step_s", *std::max_element(steps_all[k].begin(), steps_all[k].end())}};
      out.push_back(r);
    }
  }
  return out;
}

palplab::app::BenchSectionRegistration section_sleeping{
    "sleeping",
    "prototype C: sleeping / local scope vs integrating every node: speed-up and the error it "
    "costs",
    run_sleeping};
}  // namespace
