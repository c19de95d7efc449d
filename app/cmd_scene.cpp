// `palplab scene build PROTOTYPE.json --out FILE.psim [--repeat N] [--json] [--overwrite]`:
// writes the scene's precomputation to a simulation file (engine/haptics/scene_file.hpp) and
// reports how long a scene takes to become ready from it versus rebuilt from the sources (medians
// over pairs of one rebuild and one load in alternating order, each timed from nothing cached to
// the first haptic step done).
// --out is never one of the scene's sources, and an existing file that is not a .psim file (a
// results database, a prototype) is replaced only with --overwrite (app/command.hpp
// require_replaceable_output).
// `palplab scene info FILE.psim [--json]`: verifies a simulation file and prints what it holds.
#include <sys/resource.h>
#include <time.h>
#include <algorithm>
#include <filesystem>

#include <chrono>
#include <cstdio>
#include <cstdlib>
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
#include "engine/haptics/scene_file.hpp"
#include "engine/models/model.hpp"
#include "prototypes/factory.hpp"

namespace {

using namespace palplab;
using Clock = std::chrono::steady_clock;

struct BuildArgs {
  std::string prototype, out;
  int repeat = 0;  // timed pairs (--repeat); 0 without it: until enough CPU time (run_build)
  bool json = false;
  bool overwrite = false;  // --overwrite: replace an existing --out that is not a .psim file
};

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// CPU time of the process and of its reaped children (TetGen runs in a forked child,
// engine/mesh/tetrahedralize.cpp): user + system, every thread (ms). On a shared machine the wall
// time of a longer phase includes the time it waited for a core (at load average 20 on 2 cores,
// all of `scene build prototypes/B.json --repeat 7` used 80 ms of CPU in 470 ms of wall time), so
// the ratio of wall times then says more about the scheduler than about the file; CPU time
// does not count the waiting.
double cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  rusage ch{};
  getrusage(RUSAGE_CHILDREN, &ch);
  const auto tv = [](const timeval& t) { return t.tv_sec * 1e3 + t.tv_usec * 1e-3; };
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6 + tv(ch.ru_utime) + tv(ch.ru_stime);
}

// A scene is ready when it has taken its first haptic step (a FEM model factorises its system
// for the step size there).
void first_step(const engine::SceneConfig& cfg) {
  engine::Scene s = engine::make_scene(cfg);
  s.step(s.geometry().start_position);
}

nlohmann::json sources_json(const engine::SceneFileInfo& info) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& s : info.sources) {
    static const char* d = "0123456789abcdef";
    std::string h;
    for (auto b : s.sha256) h += std::string{d[b >> 4], d[b & 15]};
    a.push_back({{"role", s.role}, {"path", s.path}, {"sha256", h}});
  }
  return a;
}

// The median of the ratios a[i] / b[i] of the pairs timed together.
double median_ratio(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> r;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i)
    if (b[i] > 0) r.push_back(a[i] / b[i]);
  return r.empty() ? 0.0 : engine::median(r);
}

int run_build(const BuildArgs& a) {
  const engine::SceneConfig cfg = prototypes::load_prototype(a.prototype);
  // Checked before anything is written: --out is none of the sources (the prototype, its mesh
  // files) and replaces no file of another kind (the first 8 bytes: the .psim magic).
  std::vector<app::CommandInput> inputs = {{"the prototype file", a.prototype}};
  for (const auto& s : engine::scene_sources(cfg))
    inputs.push_back({"the " + s.role + " file of the prototype", s.path});
  app::require_replaceable_output("--out", a.out, inputs, app::has_scene_magic,
                                  "palplab scene file (.psim)", a.overwrite);
  // Rebuild (nothing cached, everything from the sources) and load (nothing cached, everything
  // from the file) are timed in pairs, the order alternating from pair to pair (rebuild first,
  // then load first), so that a machine whose load changes during the run slows both alike and
  // neither always runs in the other's wake (warm caches, a freshly trimmed heap). Without
  // --repeat the pairs go on until both sides have used kAutoCpuMs of CPU time, at least
  // kAutoMin and at most kAutoMax pairs: a prototype that loads in 0.3 ms gets a hundred pairs
  // (a median a preempted or migrated repetition cannot move), one that rebuilds in a second
  // gets seven. The file is written from the mesh the first rebuild left in the cache
  // (write_scene_file takes it from there).
  constexpr int kAutoMin = 7, kAutoMax = 201;
  constexpr double kAutoCpuMs = 300.0;
  std::vector<double> rebuild, load, rebuild_cpu, load_cpu;
  engine::SceneFileInfo info;
  bool written = false;
  double load_average[3] = {-1.0, -1.0, -1.0};
  auto time_rebuild = [&] {
    engine::install_scene_mesh(cfg.mesh, nullptr);
    const auto t0 = Clock::now();
    const double c0 = cpu_ms();
    first_step(prototypes::load_prototype(a.prototype));
    rebuild_cpu.push_back(cpu_ms() - c0);
    rebuild.push_back(ms_since(t0));
    if (!written) {
      info = engine::write_scene_file(a.out, cfg);
      written = true;
    }
  };
  auto time_load = [&] {
    engine::install_scene_mesh(cfg.mesh, nullptr);
    const auto t0 = Clock::now();
    const double c0 = cpu_ms();
    first_step(engine::load_scene_file(a.out, prototypes::load_prototype));
    load_cpu.push_back(cpu_ms() - c0);
    load.push_back(ms_since(t0));
  };
  double rebuild_total = 0, load_total = 0;
  // A file that cannot be loaded back is not left behind (the error names what is wrong with
  // it; its source is the prototype).
  struct RemoveUnlessLoaded {
    const std::string& path;
    const bool& written;
    bool loaded = false;
    ~RemoveUnlessLoaded() {
      std::error_code ec;
      if (written && !loaded) std::filesystem::remove(path, ec);
    }
  } guard{a.out, written};
  for (int i = 0;; ++i) {
    if (a.repeat > 0 ? i >= a.repeat
                     : i >= kAutoMax || (i >= kAutoMin && rebuild_total >= kAutoCpuMs &&
                                         load_total >= kAutoCpuMs))
      break;
    if (i % 2 == 0 || !written) {
      time_rebuild();
      time_load();
    } else {
      time_load();
      time_rebuild();
    }
    rebuild_total += rebuild_cpu.back();
    load_total += load_cpu.back();
  }
  guard.loaded = true;
  const int pairs = static_cast<int>(rebuild.size());
  // The machine's load when the timings were taken (1, 5, 15 min): the ratio on a busy shared
  // machine is noisier than on an idle one.
  if (getloadavg(load_average, 3) != 3) load_average[0] = load_average[1] = load_average[2] = -1;
  const double rb = engine::median(rebuild), ld = engine::median(load);
  const double rbc = engine::median(rebuild_cpu), ldc = engine::median(load_cpu);
  nlohmann::json out = {{"file", a.out},
                        {"prototype", info.prototype},
                        {"format_version", info.format_version},
                        {"palplab_version", info.tool_version},
                        {"bytes", info.bytes},
                        {"model", info.model_kind},
                        {"model_precomputation_stored", info.model_blob},
                        {"sources", sources_json(info)},
                        {"repeat", pairs},
                        {"rebuild_ms", {{"median", rb}, {"all", rebuild}}},
                        {"load_ms", {{"median", ld}, {"all", load}}},
                        {"speedup", ld > 0 ? rb / ld : 0.0},
                        {"rebuild_cpu_ms", {{"median", rbc}, {"all", rebuild_cpu}}},
                        {"load_cpu_ms", {{"median", ldc}, {"all", load_cpu}}},
                        {"speedup_cpu", ldc > 0 ? rbc / ldc : 0.0},
                        {"speedup_pairs", median_ratio(rebuild, load)},
                        {"speedup_cpu_pairs", median_ratio(rebuild_cpu, load_cpu)},
                        {"load_average", {load_average[0], load_average[1], load_average[2]}}};
  if (a.json) {
    std::cout << out.dump(2) << "\n";
  } else {
    std::cout << std::fixed << std::setprecision(1) << "wrote " << a.out << " (" << info.bytes
              << " bytes, format " << info.format_version << ", model " << info.model_kind
              << (info.model_blob ? " with its precomputation" : ", mesh precomputation only")
              << ")\n"
              << std::setprecision(2) << "  ready to step (median of " << pairs
              << " alternating pairs): rebuilt from sources " << rb << " ms, loaded from the file "
              << ld << " ms (" << std::setprecision(1) << (ld > 0 ? rb / ld : 0.0)
              << "x faster; load average " << std::setprecision(2) << load_average[0] << ")\n"
              << "  CPU time (median): rebuilt " << rbc << " ms, loaded " << ldc << " ms ("
              << std::setprecision(1) << (ldc > 0 ? rbc / ldc : 0.0)
              << "x; median of the pairs' ratios " << median_ratio(rebuild_cpu, load_cpu) << "x)\n";
  }
  return 0;
}

int run_info(const std::string& file, bool json) {
  app::refuse_directory_as_scene(file, file);
  const engine::SceneFileData d = engine::read_scene_file(file);
  const engine::SceneMesh& m = *d.mesh;
  nlohmann::json out = {{"file", file},
                        {"format_version", d.info.format_version},
                        {"palplab_version", d.info.tool_version},
                        {"bytes", d.info.bytes},
                        {"prototype", d.info.prototype},
                        {"model", d.info.model_kind},
                        {"model_precomputation_bytes", d.model_blob.size()},
                        {"surface_vertices", m.V.rows()},
                        {"surface_faces", m.F.rows()},
                        {"tet", m.tet},
                        {"model_nodes", m.model_V.rows()},
                        {"tets", m.model_T.rows()},
                        {"regions", m.region_names},
                        {"sources", sources_json(d.info)}};
  if (json) {
    std::cout << out.dump(2) << "\n";
  } else {
    std::cout << file << ": palplab scene file, format " << d.info.format_version << ", built by "
              << d.info.tool_version << ", " << d.info.bytes << " bytes, checksums ok\n"
              << "  prototype " << d.info.prototype << " (model " << d.info.model_kind << ", "
              << d.model_blob.size() << " bytes of model precomputation)\n"
              << "  surface " << m.V.rows() << " vertices, " << m.F.rows() << " faces; model "
              << m.model_V.rows() << " nodes, " << m.model_T.rows() << " tets\n";
    for (const auto& s : out["sources"])
      std::cout << "  source " << s["role"].get<std::string>() << " "
                << s["path"].get<std::string>() << " sha256 "
                << s["sha256"].get<std::string>().substr(0, 16) << "...\n";
  }
  return 0;
}

palplab::app::CommandRegistration reg_scene{
    "scene", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand("scene", "Simulation files (.psim): precomputed scenes");
      cmd->require_subcommand(1);
      auto* b = cmd->add_subcommand(
          "build", "Write a prototype's precomputation to a .psim file; report load vs rebuild");
      auto a = std::make_shared<BuildArgs>();
      b->add_option("prototype", a->prototype, "Prototype JSON file")->required();
      b->add_option("--out", a->out, "Simulation file to write (.psim)")->required();
      b->add_option("--repeat", a->repeat,
                    "Timed pairs of rebuild and load (median; default: 7 to 201 pairs, until each "
                    "side has used 0.3 s of CPU)")
          ->check(palplab::app::count_range(1, 1000));
      b->add_flag("--json", a->json, "Print JSON");
      b->add_flag("--overwrite", a->overwrite,
                  "Replace an existing --out file that is not a .psim file (never one of the "
                  "prototype's sources)");
      b->callback([a, code] { *code = run_build(*a); });
      auto* i = cmd->add_subcommand("info", "Verify a .psim file and print what it holds");
      auto file = std::make_shared<std::string>();
      auto json = std::make_shared<bool>(false);
      i->add_option("file", *file, "Simulation file (.psim)")->required();
      i->add_flag("--json", *json, "Print JSON");
      i->callback([file, json, code] { *code = run_info(*file, *json); });
    }};

}  // namespace
