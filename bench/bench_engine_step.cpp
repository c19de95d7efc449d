// Lock-step haptic step cost per prototype during a typical press (published cost budget: 10–20 us
// median), and what local integration buys: prototype C with its scope + sleeping vs the same
// model integrating every node every step (speed-up and the force/deformation error it costs).
//
// Every press is the one press script (engine/haptics/press.hpp) in the one lock-step loop,
// Scene::step timed by TimedDevice; percentiles by engine::summarize_times (nearest rank).
// Press: the contact point starts 2 mm outside the node nearest the region's centroid, pushes
// along the inward normal at 2 cm/s until 2.5 N, holds 1 s, withdraws. Only steps in contact
// are timed (a participant spends the expensive part of a session there).
//
// Sliding press (prototype C): the same press, but while holding 2.5 N the contact point moves
// across the ovary at 2 cm/s (along the ovary's long axis: engine::sliding_press). It moves C's
// integration scope; each move costs one solve of the linear exterior (`scope_exterior: linear`,
// engine/solvers/ far_field.*), timed on its own (FarField::solve_ms). Still and sliding presses
// alternate so that both see the same machine load; quote their ratio.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "engine/haptics/clock.hpp"
#include "engine/haptics/press.hpp"
#include "prototypes/factory.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {

struct Run {
  std::vector<double> us;           // per contact step
  std::vector<double> force, defo;  // per step (all steps)
  long awake_max = 0;
  // With track_scope: the contact steps that moved the scope (one exterior solve each), their
  // step times (us) and the solve's own time (us).
  std::vector<double> move_step_us, solve_us;
  std::vector<int> contact_nodes;  // distinct contact nodes in the order touched
  Eigen::Vector3d first_x = Eigen::Vector3d::Zero(),
                  last_x = Eigen::Vector3d::Zero();  // in contact
};

long exterior_solves(const Scene& s, double* last_ms) {
  const std::string info = s.stats().model_info;
  if (info.empty()) return 0;
  const auto j = nlohmann::json::parse(info);
  if (!j.contains("mass_spring")) return 0;
  const auto& m = j["mass_spring"];
  if (last_ms) *last_ms = m.value("exterior_solve_ms", 0.0);
  return m.value("exterior_solves", 0L);
}

// `spec` on s in lock-step for at most `duration` s; step times of the contact steps.
Run run(Scene& s, const PressSpec& spec, double duration, bool track_scope = false) {
  Run r;
  PressDevice press(spec);
  std::vector<double> us;
  TimedDevice timed(press, us);
  long solves = track_scope ? exterior_solves(s, nullptr) : 0;
  run_lockstep(s, timed, {.duration = duration, .frame_period = 0.0},
               [&](const Rendered& out, const Sample& x) {
                 if (out.contact) {
                   if (r.us.empty()) r.first_x = x.x;
                   r.last_x = x.x;
                   r.us.push_back(us.back());
                 }
                 if (out.contact_node >= 0 &&
                     (r.contact_nodes.empty() || r.contact_nodes.back() != out.contact_node))
                   r.contact_nodes.push_back(out.contact_node);
                 r.force.push_back(out.force.norm());
                 r.defo.push_back(out.visible_deformation);
                 r.awake_max = std::max(r.awake_max, s.stats().awake_nodes);
                 if (!track_scope) return;
                 double ms = 0.0;
                 const long now = exterior_solves(s, &ms);
                 if (now > solves) {
                   r.move_step_us.push_back(us.back());
                   r.solve_us.push_back(1e3 * ms);
                 }
                 solves = now;
               });
  return r;
}

PressSpec press_spec(const Scene& s, const std::string& region, double target = 2.5) {
  return press_at(s.geometry(), s.geometry().region_node(region), target, 1.0, 0.0);
}

// A press that does not depend on the force: ramp to `depth_max` at 2 cm/s, hold 0.7 s,
// withdraw at 5 cm/s.
Run fixed_press(Scene& s, const std::string& region, double depth_max) {
  PressSpec p = press_spec(s, region);
  p.depth = depth_max;
  p.hold = 0.7;
  p.release = 10.0;
  return run(s, p, 1.5);
}

double max_abs_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0.0;
  for (size_t k = 0; k < std::min(a.size(), b.size()); ++k) m = std::max(m, std::abs(a[k] - b[k]));
  return m;
}

double median_of(const std::vector<double>& v) {
  return summarize_times(v).median;
}

}  // namespace

// The prototypes directory: argv[1], or the source tree this file was compiled from.
std::string prototypes_dir(int argc, char** argv) {
  std::string d = argc > 1 ? std::string(argv[1]) : std::string(__FILE__);
  if (argc <= 1) d.resize(d.rfind("/bench/"));
  d.append("/prototypes/");
  return d;
}

// Sliding press on prototype C: still and sliding presses alternate (same machine load).
void sliding_press_on_c(const std::string& dir) {
  const int reps = 5;
  const double speed = 0.02;  // m/s across the ovary
  Scene s = prototypes::build_scene(dir + "C.json");
  double length = 0.0;
  const PressSpec slide = sliding_press(s.geometry(), "ovary_left", 2.5, speed, &length);
  PressSpec still = slide;  // the same press without the slide
  still.slide.setZero();
  std::vector<double> still_med, slide_med, still_all, slide_all, move_all, solve_all;
  long moves = 0;
  double peak_still = 0, peak_slide = 0, travel = 0, device_travel = 0;
  size_t nodes_touched = 0;
  for (int rep = 0; rep <= reps; ++rep) {  // rep 0 warms up
    s.reset();
    const Run a = run(s, still, slide.hold + 2.0, true);
    s.reset();
    const Run b = run(s, slide, slide.hold + 2.0, true);
    if (rep == 0) continue;
    still_med.push_back(median_of(a.us));
    slide_med.push_back(median_of(b.us));
    still_all.insert(still_all.end(), a.us.begin(), a.us.end());
    slide_all.insert(slide_all.end(), b.us.begin(), b.us.end());
    move_all.insert(move_all.end(), b.move_step_us.begin(), b.move_step_us.end());
    solve_all.insert(solve_all.end(), b.solve_us.begin(), b.solve_us.end());
    moves += static_cast<long>(b.solve_us.size());
    nodes_touched = b.contact_nodes.size();
    const auto& g = s.geometry();
    travel = (g.V.row(b.contact_nodes.back()) - g.V.row(b.contact_nodes.front())).norm();
    device_travel = (b.last_x - b.first_x).norm();
    peak_still = std::max(peak_still, *std::max_element(a.force.begin(), a.force.end()));
    peak_slide = std::max(peak_slide, *std::max_element(b.force.begin(), b.force.end()));
  }
  const TimingSummary ts = summarize_times(still_all), tl = summarize_times(slide_all),
                      tm = summarize_times(move_all), tv = summarize_times(solve_all);
  std::printf(
      "\nprototype C, ovary_left (%.1f cm long), 2.5 N held %.2f s: still vs sliding %.1f cm at"
      " %.0f cm/s (%d alternating reps; step times over the contact steps)\n",
      100 * length, slide.hold, 100 * speed * slide.hold, 100 * speed, reps);
  std::printf("%-8s %10s %10s %10s %8s %10s\n", "press", "median", "p99", "max", "peak F",
              "scope moves");
  std::printf("%-8s %8.2fus %8.2fus %8.0fus %7.3fN %10s\n", "still", median_of(still_med), ts.p99,
              ts.max, peak_still, "-");
  std::printf("%-8s %8.2fus %8.2fus %8.0fus %7.3fN %10.1f\n", "sliding", median_of(slide_med),
              tl.p99, tl.max, peak_slide, static_cast<double>(moves) / reps);
  std::printf(
      "sliding: the device moved %.1f cm in contact; the contact node changed %zu times, %.1f cm"
      " from the first to the last\n",
      100 * device_travel, nodes_touched - 1, 100 * travel);
  std::printf("sliding / still: median %.2fx, p99 %.2fx\n",
              median_of(slide_med) / median_of(still_med), tl.p99 / ts.p99);
  std::printf("scope move (exterior solve alone): median %.1fus p99 %.1fus max %.1fus (%ld)\n",
              tv.median, tv.p99, tv.max, tv.count);
  std::printf("step with a scope move (solve included): median %.1fus p99 %.1fus max %.1fus\n",
              tm.median, tm.p99, tm.max);
}

// Prototype C's backward-Euler solve options (engine/solvers/integrators.hpp): the original path
// (3x3 matrix spring blocks, last dv as CG warm start), rank_one blocks (the default), and
// rank_one with the extrapolated warm start; with refinement on (as shipped) and off. The same
// fixed 6 mm press, the variants alternating rep by rep so that all see the same machine load.
// Per variant: median over reps of the median contact-step time and its ratio to the original,
// CG iterations per step, the largest awake set, and the largest force difference from the
// original relative to its peak force (to hold against the 7 % force Weber fraction).
void solver_options_on_c(const std::string& dir, int reps) {
  struct Variant {
    const char* name;
    SpringBlocks blocks;
    WarmStart warm;
  };
  const Variant variants[] = {
      {"matrix/previous", SpringBlocks::matrix, WarmStart::previous},
      {"rank_one/previous", SpringBlocks::rank_one, WarmStart::previous},
      {"rank_one/extrap.", SpringBlocks::rank_one, WarmStart::extrapolated}};
  constexpr int nv = 3;
  std::printf("\nprototype C, fixed 6 mm press: solver options (%d alternating reps)\n", reps);
  std::printf("%-11s %-7s %-18s %9s %8s %8s %7s %9s %11s\n", "region", "refine", "blocks/warm",
              "median", "speedup", "CG it.", "awake", "peak F", "max|dF|/F");
  for (const char* region : {"ovary_left", "horn_right", "body"})
    for (bool refine : {true, false}) {
      std::vector<std::unique_ptr<Scene>> scenes;
      for (const Variant& v : variants) {
        engine::SceneConfig cfg = prototypes::load_prototype(dir + "C.json");
        cfg.solver.blocks = v.blocks;
        cfg.solver.warm_start = v.warm;
        cfg.refinement.enabled = refine;
        scenes.push_back(std::make_unique<Scene>(engine::make_scene(cfg)));
      }
      std::vector<double> med[nv];
      Run last[nv];
      double cg[nv] = {};
      for (int rep = 0; rep <= reps; ++rep)  // rep 0 warms up
        for (int v = 0; v < nv; ++v) {
          scenes[v]->reset();
          Run r = fixed_press(*scenes[v], region, 0.006);
          if (rep == 0) continue;
          med[v].push_back(median_of(r.us));
          const auto j = nlohmann::json::parse(scenes[v]->stats().model_info)["mass_spring"];
          cg[v] = j.value("cg_iterations_mean", 0.0);
          last[v] = std::move(r);
        }
      const double peak = *std::max_element(last[0].force.begin(), last[0].force.end());
      for (int v = 0; v < nv; ++v)
        std::printf("%-11s %-7s %-18s %7.2fus %7.2fx %8.2f %7ld %8.3fN %11.2e\n", region,
                    refine ? "on" : "off", variants[v].name, median_of(med[v]),
                    median_of(med[0]) / median_of(med[v]), cg[v], last[v].awake_max,
                    *std::max_element(last[v].force.begin(), last[v].force.end()),
                    max_abs_diff(last[v].force, last[0].force) / peak);
    }
}

// Arguments: [PROTOTYPES_PARENT_DIR] [--sliding] (only the sliding-press section) [--solver]
// (only the solver-options section).
int main(int argc, char** argv) {
  bool only_sliding = false, only_solver = false;
  std::vector<char*> args;
  for (int i = 0; i < argc; ++i) {
    if (std::string(argv[i]) == "--sliding")
      only_sliding = true;
    else if (std::string(argv[i]) == "--solver")
      only_solver = true;
    else
      args.push_back(argv[i]);
  }
  const std::string dir = prototypes_dir(static_cast<int>(args.size()), args.data());
  if (only_sliding) {
    sliding_press_on_c(dir);
    return 0;
  }
  if (only_solver) {
    solver_options_on_c(dir, 7);
    return 0;
  }
  std::printf("haptic step cost during a 2.5 N press (wall time of Scene::step, contact steps)\n");
  std::printf("%-4s %-11s %8s %8s %8s %7s\n", "id", "region", "median", "p99", "max", "awake");
  for (const char* id : {"A", "B", "C", "C1", "C2"})
    for (const char* region : {"ovary_left", "horn_right", "body"}) {
      Scene s = prototypes::build_scene(dir + id + ".json");
      run(s, press_spec(s, region), 4.0);  // warm-up (caches, buffers)
      s.reset();
      const Run r = run(s, press_spec(s, region), 4.0);
      const TimingSummary t = summarize_times(r.us);
      std::printf("%-4s %-11s %7.2fus %7.2fus %7.0fus %7ld\n", id, region, t.median, t.p99, t.max,
                  r.awake_max);
    }

  // Prototype B's haptic-loop scope (published: two rings 0.90 us at 1442 vertices to
  // 2.70 us at 8664, whole model 3.8 to 21.5 us): the same press with each scope on tracts of
  // several sizes.
  std::printf(
      "\nprototype B ring model: haptic step by scope (median over contact steps, ovary press)\n");
  std::printf("%-9s %10s %10s %10s %12s\n", "vertices", "rings", "octant", "whole", "whole/rings");
  for (int verts : {1500, 6000, 8664, 14392}) {
    // B.json with another tract size, written next to the system's temp files.
    std::ifstream in(dir + "B.json");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string from = "\"vertices\": 6000";
    text.replace(text.find(from), from.size(), "\"vertices\": " + std::to_string(verts));
    const std::string file = (std::filesystem::temp_directory_path() /
                              ("palplab_bench_B" + std::to_string(verts) + ".json"))
                                 .string();
    std::ofstream(file) << text;
    double med[3];
    int k = 0;
    long nv = 0;
    for (Scope sc : {Scope::rings, Scope::octant, Scope::whole}) {
      engine::SceneConfig cfg = prototypes::load_prototype(file);
      cfg.scope.rings = sc;
      Scene s = engine::make_scene(cfg);
      nv = s.geometry().V.rows();
      run(s, press_spec(s, "ovary_left"), 4.0);
      s.reset();
      med[k++] = median_of(run(s, press_spec(s, "ovary_left"), 4.0).us);
    }
    std::printf("%-9ld %8.2fus %8.2fus %8.2fus %11.1fx\n", nv, med[0], med[1], med[2],
                med[2] / med[0]);
    std::filesystem::remove(file);
  }

  // Accuracy of local integration: the same fixed device trajectory (ramp 6 mm at 2 cm/s, hold
  // 0.7 s, withdraw), so that the errors are not shifts in time of force-triggered phases.
  std::printf("\nprototype C, fixed 6 mm press: local integration vs every node every step\n");
  std::printf("%-11s %-22s %9s %8s %7s %10s %12s %12s\n", "region", "mode", "median", "speedup",
              "awake", "peak F", "max|dF| (N)", "max|dx| (um)");
  for (const char* region : {"ovary_left", "horn_right", "body"}) {
    struct Mode {
      const char* name;
      double radius;
      int cap;
      bool sleep;
    };
    const Mode modes[] = {
        {"whole (reference)", 0.0, 1 << 30, false}, {"sleeping only", 0.0, 1 << 30, true},
        {"scope 4 cm, <=192", 0.04, 192, true},     {"scope 3 cm, <=96", 0.03, 96, true},
        {"scope 3 cm, <=64 (C)", 0.03, 64, true},   {"scope 3 cm, <=48", 0.03, 48, true},
        {"scope 2 cm, <=48", 0.02, 48, true},       {"scope 2 cm, <=24", 0.02, 24, true}};
    Run ref;
    double ref_median = 0.0;
    for (const Mode& m : modes) {
      engine::SceneConfig cfg = prototypes::load_prototype(dir + "C.json");
      cfg.scope.radius = m.radius;
      cfg.scope.max_nodes = m.cap;
      cfg.sleeping.enabled = m.sleep;
      Scene s = engine::make_scene(cfg);
      const Run r = fixed_press(s, region, 0.006);
      const double med = median_of(r.us);
      if (&m == &modes[0]) {
        ref = r;
        ref_median = med;
      }
      std::printf("%-11s %-22s %7.2fus %7.1fx %7ld %9.3fN %12.4f %12.2f\n", region, m.name, med,
                  ref_median / med, r.awake_max, *std::max_element(r.force.begin(), r.force.end()),
                  max_abs_diff(r.force, ref.force), 1e6 * max_abs_diff(r.defo, ref.defo));
    }
  }

  solver_options_on_c(dir, 5);
  sliding_press_on_c(dir);
  return 0;
}
