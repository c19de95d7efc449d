// `palplab probe PROTOTYPE.json --press REGION_OR_NODE --force NEWTONS --duration SECONDS
//  [--release SECONDS] [--integrator NAME] [--json]`: a scripted press and release to
// sanity-check a prototype. The contact point starts 2 mm outside the surface node nearest to
// the region's centroid (or the given node), moves in along the inward normal at 2 cm/s until the
// device force reaches NEWTONS, holds that force (integral control of the depth) for SECONDS,
// withdraws at 5 cm/s to the start and keeps stepping for the release time.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "app/command.hpp"
#include "common/input_error.hpp"
#include "engine/haptics/scene_impl.hpp"
#include "prototypes/factory.hpp"

namespace {

struct ProbeArgs {
  std::string file, press, integrator;
  double force = 0.0, duration = 0.0, release = 1.0;
  bool json = false;
};

int run_probe(const ProbeArgs& a) {
  using namespace palplab;
  if (!(a.force > 0.0) || !std::isfinite(a.force))
    throw InputError("--force: expected a positive force in N, got " + std::to_string(a.force));
  if (!(a.duration >= 0.0) || a.duration > 3600)
    throw InputError("--duration: expected a hold time in s in [0, 3600]");
  if (!(a.release >= 0.0) || a.release > 3600)
    throw InputError("--release: expected a time in s in [0, 3600]");
  engine::SceneOverrides ov;
  if (!a.integrator.empty()) {
    if (a.integrator != "symplectic_euler" && a.integrator != "backward_euler" &&
        a.integrator != "rk4")
      throw InputError("--integrator: unknown integrator \"" + a.integrator +
                       "\" (expected symplectic_euler, backward_euler or rk4)");
    ov.integrator = a.integrator;
  }
  engine::Scene scene = prototypes::build_scene(a.file, ov);
  if (!a.integrator.empty() && scene.impl().kind != engine::ModelKind::mass_spring)
    throw InputError("--integrator: prototype " + scene.prototype() + " has a " +
                     engine::to_string(scene.impl().kind) +
                     " model, which is not time-integrated (the option applies to mass_spring "
                     "prototypes)");
  const auto& g = scene.geometry();
  int node = -1;
  if (g.region_index(a.press) >= 0) {
    node = g.region_node(a.press);
  } else {
    bool digits = !a.press.empty() && std::all_of(a.press.begin(), a.press.end(),
                                                  [](char c) { return c >= '0' && c <= '9'; });
    if (digits && a.press.size() < 10) node = std::stoi(a.press);
    if (node < 0 || node >= g.V.rows()) {
      std::string names;
      for (const auto& r : g.region_names) names += (names.empty() ? "" : ", ") + r;
      throw InputError("--press: \"" + a.press + "\" is neither a region (" +
                       (names.empty() ? "this mesh has none" : names) +
                       ") nor a node index in [0, " + std::to_string(g.V.rows() - 1) + "]");
    }
  }
  const Eigen::Vector3d p = g.V.row(node).transpose(), n = g.N.row(node).transpose();
  const double dt = scene.dt();
  const engine::SceneStats s0 = scene.stats();

  std::vector<double> times;
  times.reserve(static_cast<size_t>((a.duration + a.release + 10.0) / dt));
  double peak_force = 0.0, peak_disp = 0.0, time_to_force = -1.0;
  bool nan = false;
  nlohmann::json events = nlohmann::json::array();
  auto step = [&](const Eigen::Vector3d& x) {
    const auto t0 = std::chrono::steady_clock::now();
    const engine::Rendered r = scene.step(x);
    const auto t1 = std::chrono::steady_clock::now();
    times.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    const double f = r.force.norm();
    if (!std::isfinite(f)) nan = true;
    peak_force = std::max(peak_force, f);
    peak_disp = std::max(peak_disp, r.visible_deformation);
    for (const auto& e : r.events)
      events.push_back({{"t", e.t},
                        {"kind", engine::to_string(e.kind)},
                        {"region", e.region >= 0 ? g.region_names[e.region] : ""},
                        {"value", e.value}});
    return r;
  };
  // 1. approach and press
  double depth = -0.002;  // m below the rest surface (negative = outside)
  const double v_in = 0.02, v_out = 0.05, max_depth = 0.06, max_press_time = 10.0;
  double t = 0.0;
  engine::Rendered r;
  bool reached = false;
  while (t < max_press_time && depth < max_depth) {
    r = step(p - depth * n);
    t += dt;
    if (r.force.norm() >= a.force) {
      reached = true;
      time_to_force = t;
      break;
    }
    depth += v_in * dt;
  }
  // 2. hold the force
  const engine::SceneImpl& impl = scene.impl();
  const double gain = 0.2 / std::max(impl.contact_k, 1.0);  // m per N per step
  for (double th = 0.0; th < a.duration; th += dt) {
    r = step(p - depth * n);
    depth += gain * (a.force - r.force.norm());
  }
  const engine::SceneStats s_loaded = scene.stats();
  // 3. withdraw to the start point, then let it settle
  while (depth > -0.002) {
    depth -= v_out * dt;
    r = step(p - depth * n);
  }
  for (double tr = 0.0; tr < a.release; tr += dt) step(p + 0.002 * n);
  const engine::SceneStats s1 = scene.stats();
  nan = nan || s1.nan_detected;

  std::vector<double> sorted = times;
  std::sort(sorted.begin(), sorted.end());
  auto pct = [&](double q) {
    if (sorted.empty()) return 0.0;
    return sorted[std::min(sorted.size() - 1, static_cast<size_t>(q * (sorted.size() - 1) + 0.5))];
  };
  nlohmann::json out = {
      {"prototype", scene.prototype()},
      {"model", engine::to_string(impl.kind)},
      {"node", node},
      {"region", g.vertex_region[node] >= 0 ? g.region_names[g.vertex_region[node]] : ""},
      {"target_force", a.force},
      {"force_reached", reached},
      {"time_to_force", time_to_force},
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
      {"step_time_us",
       {{"median", pct(0.5)}, {"p99", pct(0.99)}, {"max", sorted.empty() ? 0.0 : sorted.back()}}},
      {"nan_detected", nan},
      {"events", events}};
  if (a.json) {
    std::cout << out.dump(2) << "\n";
  } else {
    std::cout << "prototype " << scene.prototype() << " (" << engine::to_string(impl.kind)
              << "), press node " << node << " (" << out["region"].get<std::string>() << ")\n"
              << "  peak force " << peak_force << " N" << (reached ? "" : " (target NOT reached)")
              << ", peak visible displacement " << peak_disp * 1e3 << " mm\n"
              << "  mass " << s0.total_mass << " -> " << s1.total_mass
              << " kg, rest error after release " << s1.max_rest_error << " m\n"
              << "  nodes " << s0.nodes << ", springs " << s0.springs << ", new nodes "
              << s1.new_nodes_max << ", new springs " << s1.new_springs_max << "\n"
              << "  step time median " << pct(0.5) << " us, p99 " << pct(0.99) << " us"
              << (nan ? ", NaN detected" : "") << "\n";
  }
  return nan ? 1 : 0;
}

palplab::app::CommandRegistration reg{
    "probe", [](CLI::App& root, int* code) {
      auto* cmd =
          root.add_subcommand("probe", "Scripted press and release on a prototype (sanity check)");
      auto a = std::make_shared<ProbeArgs>();
      cmd->add_option("prototype", a->file, "Prototype JSON file")->required();
      cmd->add_option("--press", a->press, "Region name or surface node index to press")
          ->required();
      cmd->add_option("--force", a->force, "Target device force (N)")->required();
      cmd->add_option("--duration", a->duration, "Hold time at the target force (s)")->required();
      cmd->add_option("--release", a->release,
                      "Time to keep simulating after withdrawal (s), default 1");
      cmd->add_option("--integrator", a->integrator,
                      "symplectic_euler | backward_euler | rk4 (mass-spring models)");
      cmd->add_flag("--json", a->json, "Print JSON");
      cmd->callback([a, code] { *code = run_probe(*a); });
    }};

}  // namespace
