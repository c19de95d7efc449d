#include "app/bench_scene.hpp"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "common/input_error.hpp"

namespace palplab::app {

std::string prototype_variant(const BenchOptions& o, const std::string& id, const std::string& tag,
                              const std::function<void(nlohmann::json&)>& edit) {
  const std::string src = o.prototypes_dir() + "/" + id + ".json";
  std::ifstream in(src);
  if (!in) throw InputError("cannot read the prototype (pass --data pointing at tests/data)", src);
  nlohmann::json j = nlohmann::json::parse(in);
  edit(j);
  const auto dir = std::filesystem::temp_directory_path() /
                   ("palplab_bench_" + std::to_string(static_cast<long>(::getpid())));
  std::filesystem::create_directories(dir);
  const std::string file = (dir / (id + "_" + tag + ".json")).string();
  std::ofstream(file) << j.dump(2) << "\n";
  return file;
}

PressTrace fixed_press(engine::Scene& s, const std::string& region, double depth_max, int steps) {
  using Clock = std::chrono::steady_clock;
  PressTrace r;
  const auto& g = s.geometry();
  const int node = g.region_node(region);
  const Eigen::Vector3d p = g.V.row(node).transpose(), n = g.N.row(node).transpose();
  for (int k = 0; k < steps; ++k) {
    const double depth = std::min(depth_max, -0.002 + 0.02 * k * s.dt());
    const auto t0 = Clock::now();
    const engine::Rendered out = s.step(p - depth * n);
    const double dt = std::chrono::duration<double>(Clock::now() - t0).count();
    r.step_s.push_back(dt);
    if (out.contact) r.contact_step_s.push_back(dt);
    r.force.push_back(out.force.norm());
    r.deformation.push_back(out.visible_deformation);
    r.depth.push_back(depth);
    const auto st = s.stats();
    r.awake_max = std::max(r.awake_max, st.awake_nodes);
    r.diverged = r.diverged || st.nan_detected;
  }
  return r;
}

double max_rel_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0, ref = 0;
  for (size_t k = 0; k < std::min(a.size(), b.size()); ++k) {
    m = std::max(m, std::abs(a[k] - b[k]));
    ref = std::max(ref, std::abs(b[k]));
  }
  return ref > 0 ? m / ref : m;
}

void write_figure(const BenchOptions& o, const std::string& file, const std::string& svg) {
  if (o.svg_dir.empty()) return;
  const std::string path = o.svg_dir + "/" + file;
  std::ofstream out(path);
  if (!out) throw InputError("cannot write the figure", path);
  out << svg;
}

}  // namespace palplab::app
