// `palplab bench haptic_scope`: prototype B's haptic step (ring model) with the three scopes of
// docs/FORMATS.md (rings = the displaced/moving nodes only, octant = plus the touched node's
// octree leaf, whole = every node) on tracts of 1.5k ... 23k vertices. One repetition is one
// fixed press on the left ovary (ramp to 5 mm at 2 cm/s, hold); its sample is the median wall
// time of the steps in contact. Published (SPEC §3, Pentium IV): two rings 0.90 us at 1442
// vertices to 2.70 us at 8664, whole model 3.8 to 21.5 us.
#include "analysis/svg.hpp"
#include "app/bench.hpp"
#include "app/bench_scene.hpp"
#include "engine/haptics/clock.hpp"
#include "prototypes/factory.hpp"

namespace {
using namespace palplab;
using palplab::app::BenchOptions;
using palplab::app::BenchResult;

std::vector<BenchResult> run_haptic_scope(const BenchOptions& o) {
  const std::vector<int> sizes =
      o.quick ? std::vector<int>{1500, 6000} : std::vector<int>{1442, 3000, 8664, 14392, 23000};
  const std::vector<std::string> scopes = {"rings", "octant", "whole"};
  const int reps = o.quick ? 5 : 7,
            steps = o.quick ? 400 : 700;  // the ramp to 5 mm takes 350 steps
  std::vector<BenchResult> out;
  std::vector<analysis::Series> series(scopes.size());
  for (size_t k = 0; k < scopes.size(); ++k) series[k].name = scopes[k], series[k].colour = k;
  for (int n : sizes) {
    std::vector<engine::Scene> scenes;
    for (const auto& sc : scopes)
      scenes.push_back(prototypes::build_scene(
          app::prototype_variant(o, "B", sc + std::to_string(n), [&](nlohmann::json& j) {
            j["mesh"]["vertices"] = n;
            j["model"]["scope"] = sc;
          })));
    const long nv = scenes[0].geometry().V.rows();
    std::vector<std::vector<double>> med(scopes.size()), all(scopes.size());
    std::vector<double> cold(scopes.size()), peak(scopes.size());
    for (int rep = 0; rep <= reps; ++rep)  // interleaved: every scope sees the same machine load
      for (size_t k = 0; k < scopes.size(); ++k) {
        scenes[k].reset();
        const app::PressTrace t = app::fixed_press(scenes[k], "ovary_left", 0.005, steps);
        const double m = engine::median(t.contact_step_s);
        peak[k] = *std::max_element(t.force.begin(), t.force.end());
        if (rep == 0) {
          cold[k] = m;
          continue;
        }
        med[k].push_back(m);
        all[k].insert(all[k].end(), t.contact_step_s.begin(), t.contact_step_s.end());
      }
    const double whole = engine::median(med[2]);
    for (size_t k = 0; k < scopes.size(); ++k) {
      BenchResult r =
          app::result_from_samples("B" + std::to_string(nv) + "_" + scopes[k],
                                   "prototype B, " + std::to_string(nv) + " vertices, scope " +
                                       scopes[k] + " (s per contact step)",
                                   med[k], cold[k]);
      r.metrics = {{"vertices", static_cast<double>(nv)},
                   {"p99_s", engine::quantile(all[k], 0.99)},
                   {"whole_over_this", whole / r.median_s},
                   {"peak_force_N", peak[k]}};
      series[k].x.push_back(static_cast<double>(nv));
      series[k].y.push_back(r.median_s * 1e6);
      series[k].lo.push_back(r.min_s * 1e6);
      series[k].hi.push_back(r.max_s * 1e6);
      out.push_back(r);
    }
  }
  app::write_figure(o, "haptic_scope.svg",
                    analysis::svg_line_plot(series, "Prototype B haptic step by scope",
                                            "tract vertices", "median step time (us)"));
  return out;
}

palplab::app::BenchSectionRegistration section_haptic_scope{
    "haptic_scope", "prototype B haptic step: rings / octant / whole scope, 1.5k-23k vertices",
    run_haptic_scope};
}  // namespace
