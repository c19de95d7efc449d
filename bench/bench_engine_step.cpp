// Lock-step haptic step cost per prototype during a typical press (published cost budget: 10–20 us
// median), and what local integration buys: prototype C with its scope + sleeping vs the same
// model integrating every node every step (speed-up and the force/deformation error it costs).
//
// Press: the contact point starts 2 mm outside the node nearest the region's centroid, pushes
// along the inward normal at 2 cm/s until 2.5 N, holds 1 s, withdraws. Only steps in contact
// are timed (a participant spends the expensive part of a session there).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "prototypes/factory.hpp"

using namespace palplab;
using namespace palplab::engine;
using Clock = std::chrono::steady_clock;

namespace {

struct Run {
  std::vector<double> us;           // per contact step
  std::vector<double> force, defo;  // per step (all steps)
  long awake_max = 0;
};

double pct(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(q * (v.size() - 1) + 0.5)];
}

// One timed Scene::step, recorded into `r` (step time only while in contact).
Rendered timed_step(Scene& s, const Eigen::Vector3d& x, Run& r) {
  const auto t0 = Clock::now();
  const Rendered out = s.step(x);
  const double us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
  if (out.contact) r.us.push_back(us);
  r.force.push_back(out.force.norm());
  r.defo.push_back(out.visible_deformation);
  r.awake_max = std::max(r.awake_max, s.stats().awake_nodes);
  return out;
}

Run press(Scene& s, const std::string& region, double target = 2.5) {
  Run r;
  const auto& g = s.geometry();
  const int node = g.region_node(region);
  const Eigen::Vector3d p = g.V.row(node).transpose(), n = g.N.row(node).transpose();
  double depth = -0.002;
  int phase = 0, hold = 0;
  for (int k = 0; k < 4000 && phase < 3; ++k) {
    const Rendered out = timed_step(s, p - depth * n, r);
    if (phase == 0) {
      depth += 0.02 * s.dt();
      if (out.force.norm() >= target) phase = 1;
    } else if (phase == 1) {
      if (++hold >= 1000) phase = 2;
    } else {
      depth -= 0.05 * s.dt();
      if (depth < -0.002) phase = 3;
    }
  }
  return r;
}

// A press that does not depend on the force: ramp to `depth_max` at 2 cm/s, hold 0.7 s,
// withdraw at 5 cm/s.
Run fixed_press(Scene& s, const std::string& region, double depth_max) {
  Run r;
  const auto& g = s.geometry();
  const int node = g.region_node(region);
  const Eigen::Vector3d p = g.V.row(node).transpose(), n = g.N.row(node).transpose();
  const double t_in = (depth_max + 0.002) / 0.02, t_hold = t_in + 0.7;
  for (int k = 0; k < 1500; ++k) {
    const double t = k * s.dt();
    const double depth = t < t_in     ? -0.002 + 0.02 * t
                         : t < t_hold ? depth_max
                                      : std::max(-0.002, depth_max - 0.05 * (t - t_hold));
    timed_step(s, p - depth * n, r);
  }
  return r;
}

double max_abs_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0.0;
  for (size_t k = 0; k < std::min(a.size(), b.size()); ++k) m = std::max(m, std::abs(a[k] - b[k]));
  return m;
}

}  // namespace

// The prototypes directory: argv[1], or the source tree this file was compiled from.
std::string prototypes_dir(int argc, char** argv) {
  std::string d = argc > 1 ? std::string(argv[1]) : std::string(__FILE__);
  if (argc <= 1) d.resize(d.rfind("/bench/"));
  d.append("/prototypes/");
  return d;
}

int main(int argc, char** argv) {
  const std::string dir = prototypes_dir(argc, argv);
  std::printf("haptic step cost during a 2.5 N press (wall time of Scene::step, contact steps)\n");
  std::printf("%-4s %-11s %8s %8s %8s %8s %7s\n", "id", "region", "median", "p90", "p99", "max",
              "awake");
  for (const char* id : {"A", "B", "C", "C1", "C2"})
    for (const char* region : {"ovary_left", "horn_right", "body"}) {
      Scene s = prototypes::build_scene(dir + id + ".json");
      press(s, region);  // warm-up (caches, buffers)
      s.reset();
      const Run r = press(s, region);
      std::printf("%-4s %-11s %7.2fus %7.2fus %7.2fus %7.0fus %7ld\n", id, region, pct(r.us, 0.5),
                  pct(r.us, 0.9), pct(r.us, 0.99), pct(r.us, 1.0), r.awake_max);
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
      press(s, "ovary_left");
      s.reset();
      med[k++] = pct(press(s, "ovary_left").us, 0.5);
    }
    std::printf("%-9ld %8.2fus %8.2fus %8.2fus %11.1fx\n", nv, med[0], med[1], med[2],
                med[2] / med[0]);
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
      const double med = pct(r.us, 0.5);
      if (&m == &modes[0]) {
        ref = r;
        ref_median = med;
      }
      std::printf("%-11s %-22s %7.2fus %7.1fx %7ld %9.3fN %12.4f %12.2f\n", region, m.name, med,
                  ref_median / med, r.awake_max, *std::max_element(r.force.begin(), r.force.end()),
                  max_abs_diff(r.force, ref.force), 1e6 * max_abs_diff(r.defo, ref.defo));
    }
  }
  return 0;
}
