#include "app/bench_scene.hpp"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "common/input_error.hpp"
#include "common/write_file.hpp"
#include "engine/haptics/clock.hpp"
#include "engine/haptics/press.hpp"

namespace palplab::app {

const std::filesystem::path& bench_scratch_dir() {
  struct Scratch {
    std::filesystem::path dir;
    Scratch()
        : dir(std::filesystem::temp_directory_path() /
              ("palplab_bench_" + std::to_string(static_cast<long>(::getpid())))) {
      std::filesystem::create_directories(dir);
    }
    ~Scratch() {
      std::error_code ec;  // nothing to report at exit
      std::filesystem::remove_all(dir, ec);
    }
  };
  static const Scratch scratch;
  return scratch.dir;
}

std::string prototype_variant(const BenchOptions& o, const std::string& id, const std::string& tag,
                              const std::function<void(nlohmann::json&)>& edit) {
  const std::string src = o.prototypes_dir() + "/" + id + ".json";
  std::ifstream in(src);
  if (!in) throw InputError("cannot read the prototype (pass --data pointing at tests/data)", src);
  nlohmann::json j = nlohmann::json::parse(in);
  edit(j);
  const std::string file = (bench_scratch_dir() / (id + "_" + tag + ".json")).string();
  write_file(file, j.dump(2) + "\n", "a prototype variant for the benchmark");
  return file;
}

PressTrace fixed_press(engine::Scene& s, const std::string& region, double depth_max, int steps) {
  PressTrace r;
  engine::PressSpec spec =
      engine::press_at(s.geometry(), s.geometry().region_node(region), 1.0, 1e3, 0.0);
  spec.depth = depth_max;  // position control: the same trajectory for every model
  engine::PressDevice press(spec);
  std::vector<double> us;
  us.reserve(steps);
  engine::TimedDevice timed(press, us);
  engine::run_lockstep(s, timed, {.duration = steps * s.dt(), .frame_period = 0.0},
                       [&](const engine::Rendered& out, const engine::Sample& x) {
                         const double dt = 1e-6 * us.back();
                         r.step_s.push_back(dt);
                         if (out.contact) r.contact_step_s.push_back(dt);
                         r.force.push_back(out.force.norm());
                         r.deformation.push_back(out.visible_deformation);
                         r.depth.push_back(spec.normal.dot(spec.point - x.x));
                         const auto st = s.stats();
                         r.awake_max = std::max(r.awake_max, st.awake_nodes);
                         r.diverged = r.diverged || st.nan_detected;
                       });
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
  write_file(path, svg, "the figure");
}

}  // namespace palplab::app
