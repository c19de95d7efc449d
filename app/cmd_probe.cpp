// `palplab probe PROTOTYPE.json --press REGION_OR_NODE --force NEWTONS --duration SECONDS
//  [--release SECONDS] [--integrator NAME] [--json] [--trace FILE.csv]`: a scripted press and
// release to sanity-check a prototype. The contact point starts 2 mm outside the surface node
// nearest to the region's centroid (or the given node), moves in along the inward normal at 2 cm/s
// until the device force reaches NEWTONS, holds that force (integral control of the depth) for
// SECONDS, withdraws at 5 cm/s to the start and keeps stepping for the release time. --trace writes
// every step (time, script phase, device position, rendered force, contact node, visible
// deformation; SI units) as CSV, written as the steps run.
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "app/command.hpp"
#include "app/scene_option.hpp"
#include "common/input_error.hpp"
#include "engine/haptics/clock.hpp"
#include "engine/haptics/press.hpp"
#include "engine/haptics/scene_file.hpp"
#include "prototypes/factory.hpp"

namespace {
// A peak force above this multiple of a renderable target is a bounce, not a press.
constexpr double kOvershoot = 1.25;
// --trace's header: its columns (SI units; phase: approach, hold, withdraw, release, done).
constexpr const char* kTraceHeader =
    "t_s,phase,x_m,y_m,z_m,fx_n,fy_n,fz_n,force_n,contact_node,visible_deformation_m";

struct ProbeArgs {
  std::string file, press, integrator, trace;
  bool overwrite = false;          // --overwrite: replace a --trace file of another kind
  bool trace_given = false;        // --trace was given (an empty name is refused)
  std::vector<std::string> scene;  // --scene FILE.psim | KEY (app/scene_option.hpp)
  double force = 0.0, duration = 0.0, release = 1.0;
  bool json = false;
};

int run_probe(const ProbeArgs& a) {
  using namespace palplab;
  // --force, --duration and --release are range-checked by their validators (app/command.hpp).
  engine::SceneOverrides ov;
  if (!a.integrator.empty()) {
    if (a.integrator != "symplectic_euler" && a.integrator != "backward_euler" &&
        a.integrator != "rk4")
      throw InputError("--integrator: unknown integrator \"" + a.integrator +
                       "\" (expected symplectic_euler, backward_euler or rk4)");
    ov.integrator = a.integrator;
  }
  engine::Scene scene = prototypes::build_scene(app::scene_prototype(a.file, a.scene), ov);
  if (!a.integrator.empty() && std::string(scene.model_kind()) != "mass_spring")
    throw InputError("--integrator: prototype " + scene.prototype() + " has a " +
                     scene.model_kind() +
                     " model, which integrates with its own fixed scheme (the option chooses "
                     "the integrator of mass_spring prototypes only)");
  const auto& g = scene.geometry();
  int node = -1;
  try {
    node = engine::press_node(g, a.press);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("--press: ") + e.what());
  }
  const engine::SceneStats s0 = scene.stats();
  engine::PressDevice press(engine::press_at(g, node, a.force, a.duration, a.release));
  std::ofstream trace;
  if (a.trace_given && a.trace.empty())
    throw InputError(SourceLocation{"--trace"}, "expected a file name, got an empty one");
  if (!a.trace.empty()) {
    // Never an input (the prototype, its mesh, a --scene file), nor a file of another kind
    // without --overwrite; its own earlier output starts with the header.
    std::vector<app::CommandInput> inputs;
    if (!a.file.empty()) inputs.push_back({"the prototype file", a.file});
    for (const auto& sc : a.scene) inputs.push_back({"the --scene file", sc});
    for (const auto& src : engine::scene_sources(scene.config()))
      inputs.push_back({"the " + src.role + " file of the prototype", src.path});
    app::require_replaceable_output(
        "--trace", a.trace, inputs,
        [](const std::string& p) { return app::file_starts_with(p, kTraceHeader); },
        "probe trace (CSV)", a.overwrite);
    trace.open(a.trace, std::ios::binary | std::ios::trunc);
    if (!trace) throw InputError(SourceLocation{"--trace"}, "cannot write \"" + a.trace + "\"");
    trace << kTraceHeader << "\n";
  }

  std::vector<double> times;
  times.reserve(static_cast<size_t>((a.duration + a.release + 10.0) / scene.dt()));
  double peak_force = 0.0, peak_disp = 0.0;
  bool nan = false, loaded_taken = false;
  engine::SceneStats s_loaded = s0;
  nlohmann::json events = nlohmann::json::array();
  // The step time is measured around Scene::step alone (the device and the logging are not).
  engine::TimedDevice timed(press, times);
  engine::LockstepOptions opt;
  opt.duration = 1e6;  // the press script ends the run
  opt.frame_period = 0.0;
  engine::run_lockstep(
      scene, timed, opt, [&](const engine::Rendered& r, const engine::Sample& smp) {
        const double f = r.force.norm();
        if (!std::isfinite(f)) nan = true;
        if (trace.is_open()) {
          char line[320];
          const Eigen::Vector3d& x = smp.x;  // the device position this step rendered
          std::snprintf(line, sizeof line, "%.6f,%s,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%d,%.9g\n",
                        r.t, engine::to_string(press.phase()), x.x(), x.y(), x.z(), r.force.x(),
                        r.force.y(), r.force.z(), f, r.contact_node, r.visible_deformation);
          trace << line;
        }
        peak_force = std::max(peak_force, f);
        peak_disp = std::max(peak_disp, r.visible_deformation);
        for (const auto& e : r.events)
          events.push_back({{"t", e.t},
                            {"kind", engine::to_string(e.kind)},
                            {"region", e.region >= 0 ? g.region_names[e.region] : ""},
                            {"value", e.value}});
        if (!loaded_taken && press.phase() == engine::PressPhase::withdraw) {
          s_loaded = scene.stats();  // the state at the end of the hold
          loaded_taken = true;
        }
      });
  if (trace.is_open()) {
    trace.close();
    if (!trace)
      throw InputError(SourceLocation{"--trace"},
                       "cannot write \"" + a.trace + "\" (" + std::strerror(errno) + ")");
  }
  const bool reached = press.force_reached();
  const double time_to_force = press.time_to_force();
  const engine::SceneStats s1 = scene.stats();
  nan = nan || s1.nan_detected;

  const engine::TimingSummary st = engine::summarize_times(times);
  nlohmann::json out = {
      {"prototype", scene.prototype()},
      {"model", scene.model_kind()},
      {"node", node},
      {"region", g.vertex_region[node] >= 0 ? g.region_names[g.vertex_region[node]] : ""},
      {"target_force", a.force},
      {"force_reached", reached},
      // null when the force was not reached (it was -1, a time: review 2026-12-06, eighth).
      {"time_to_force", reached ? nlohmann::json(time_to_force) : nlohmann::json(nullptr)},
      {"peak_force", peak_force},
      {"peak_displacement", peak_disp},
      {"mass_initial", s0.total_mass},
      {"mass_final", s1.total_mass},
      {"mass_loaded", s_loaded.total_mass},
      {"max_rest_error_after_release", s1.max_rest_error},
      {"nodes", s0.nodes},
      {"springs", s0.springs},
      {"new_nodes", s1.new_nodes_max},
      {"new_springs", s1.new_springs_max},
      {"level_loaded", s_loaded.level},
      {"steps", static_cast<long>(times.size())},
      {"step_time_us", {{"median", st.median}, {"p99", st.p99}, {"max", st.max}}},
      {"nan_detected", nan},
      {"divergences", s1.divergences},
      {"force_limited_steps", s1.force_limited},
      {"events", events}};
  // Model-specific sections (model "fem": "fem": {formulation, dofs, solver, factor_ms, ...}).
  if (!s1.model_info.empty()) out.update(nlohmann::json::parse(s1.model_info));
  // Said, not left to be inferred (review 2026-12-06, second): a target above the device's
  // force limit cannot be reached, and a diverged simulation's numbers mean nothing.
  const double limit = scene.config().contact.force_limit;
  if (!reached && a.force > limit)
    std::cerr << "note: --force " << a.force << " N is above the prototype's device force limit ("
              << limit << " N, contact.force_limit): the force on the hand is clamped there\n";
  if (nan)
    std::cerr << "warning: the simulation produced NaN (" << s1.divergences
              << " divergences): the numbers reported are not valid; exit 1\n";
  // A contact that injects energy, or whose force had to be clamped below a target the device
  // can render, bounced: bounded by the watchdog and logged, but not the press asked for (a
  // pad of 1e5 N/m on C or D gave exit 0 with 5 contact starts and 34 N unclamped for 2.5 N;
  // review 2026-12-07).
  long injected = 0, limited = 0;
  for (const auto& e : events) {
    injected += e["kind"] == "energy_injected";
    limited += e["kind"] == "force_limited";
  }
  // A peak far above a target the device can render is the same bounce below the watchdog's
  // thresholds (C at 3e4-1e5 N/m: 2.6-7.3 N for 2 N, exit 0; review of the fix, 2026-12-07);
  // the press controller itself overshoots by well under 5 % on the shipped prototypes.
  const bool overshoot = a.force <= limit && peak_force > kOvershoot * a.force;
  const bool unstable = !nan && (injected > 0 || (limited > 0 && a.force <= limit) || overshoot);
  if (unstable)
    std::cerr << "warning: the contact was not stable (" << injected << " energy_injected and "
              << limited << " force_limited event" << (injected + limited == 1 ? "" : "s")
              << ", peak force " << peak_force << " N for a target of " << a.force
              << " N; contact.stiffness " << scene.config().contact.stiffness
              << " N/m): the press bounced and the numbers reported are not those of a steady "
                 "press; lower contact.stiffness; exit 1\n";
  out["contact_stable"] = !unstable && !nan;
  if (a.json) {
    std::cout << out.dump(2) << "\n";
  } else {
    std::cout << "prototype " << scene.prototype() << " (" << scene.model_kind() << "), press node "
              << node << " ("
              << (out["region"].get<std::string>().empty() ? std::string("in no region")
                                                           : out["region"].get<std::string>())
              << ")\n"
              << "  peak force " << peak_force << " N" << (reached ? "" : " (target NOT reached)")
              << ", peak visible displacement " << peak_disp * 1e3 << " mm\n"
              << "  mass " << s0.total_mass << " -> " << s1.total_mass
              << " kg, rest error after release " << s1.max_rest_error << " m\n"
              << "  nodes " << s0.nodes << ", springs " << s0.springs << ", new nodes "
              << s1.new_nodes_max << ", new springs " << s1.new_springs_max << "\n"
              << "  step time median " << st.median << " us, p99 " << st.p99 << " us"
              << (nan ? ", NaN detected" : "") << "\n";
    if (out.contains("fem")) {
      const auto& f = out["fem"];
      std::cout << "  fem " << f["formulation"].get<std::string>() << ", " << f["dofs"]
                << " dofs per step, factorisation " << f["factor_ms"] << " ms ("
                << f["solver"].get<std::string>() << ")\n";
    }
  }
  return nan || unstable ? 1 : 0;
}

palplab::app::CommandRegistration reg_probe{
    "probe", [](CLI::App& root, int* code) {
      auto* cmd =
          root.add_subcommand("probe", "Scripted press and release on a prototype (sanity check)");
      auto a = std::make_shared<ProbeArgs>();
      cmd->add_option("prototype", a->file, "Prototype JSON file (or --scene)");
      palplab::app::add_scene_option(cmd, a->scene, false);
      cmd->add_option("--press", a->press, "Region name or surface node index to press")
          ->required();
      // Validators that refuse NaN and inf and echo the value given ("--force nan" printed
      // "got null", the JSON spelling of NaN).
      using palplab::app::finite_range;
      cmd->add_option("--force", a->force, "Target device force (N), in (0, 100]")
          ->required()
          ->check(finite_range(0, 100, true));
      cmd->add_option("--duration", a->duration, "Hold time at the target force (s)")
          ->required()
          ->check(finite_range(0, 3600));
      cmd->add_option("--release", a->release,
                      "Time to keep simulating after withdrawal (s), default 1")
          ->check(finite_range(0, 3600));
      cmd->add_option("--integrator", a->integrator,
                      "symplectic_euler | backward_euler | rk4 (mass-spring models)");
      cmd->add_flag("--json", a->json, "Print JSON");
      auto* trace_opt =
          cmd->add_option("--trace", a->trace,
                          "Write every step as CSV (t_s, phase, device position x/y/z_m, force "
                          "fx/fy/fz_n and its norm, contact_node, visible_deformation_m)");
      cmd->add_flag("--overwrite", a->overwrite,
                    "Replace an existing --trace file that is not a probe trace");
      cmd->callback([a, code, trace_opt] {
        a->trace_given = trace_opt->count() > 0;
        *code = run_probe(*a);
      });
    }};

}  // namespace
