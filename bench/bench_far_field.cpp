// Prototype C's exterior solve beside the haptic loop (issue 9; engine/solvers/far_field.hpp):
// the haptic step during a sliding press with the exterior solved in the step (sync) against
// the worker thread (deterministic: adopted exactly `latency` steps after the scope moved;
// async: adopted when finished, the real-time mode).
//
// The press: 2.5 N on the left ovary, then the contact point slides along the ovary's long axis
// at `speed` while holding (each scope re-centre, every quarter scope radius, requests one
// solve of the whole model). Modes alternate within each repetition (same machine load); the
// step times are Scene::step's wall time over the contact steps, pooled over the repetitions:
// median, p99 (nearest rank, engine::summarize_times) and the max step. Two loops:
//   lock-step: steps back to back (as the virtual participants run); a deterministic adoption
//              then waits for the rest of the solve when the steps outrun it (counted);
//   1 kHz:     each step starts on a 1 ms tick (run_lockstep's `paced`, the ticks of
//              engine::run_realtime): the pacing of a human session; the worker has `latency` ms
//              for a solve.
// Also printed: the scope moves and what became of them (adopted, waits, late, most steps from
// a move to its exterior) and the largest force difference to the sync run of the same press
// (the cost of the latency in the rendered force), the contact steps over the 1 ms budget, and
// the wall time of the steps that moved the scope and of those that adopted its new exterior.
//
// Arguments: [PROTOTYPES_DIR] [--reps N] [--speed M_PER_S] [--latency STEPS]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "engine/haptics/clock.hpp"
#include "engine/haptics/press.hpp"
#include "prototypes/factory.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {

struct Mode {
  const char* name;
  bool worker, realtime;
};

struct Result {
  std::vector<double> us;                 // contact steps
  std::vector<double> force;              // every step (N)
  std::vector<double> move_us, adopt_us;  // the steps that moved the scope / adopted its exterior
  long over_1ms = 0;                      // contact steps over the 1 ms haptic budget
  long node_changes = 0;                  // the contact node changed (in contact)
  long moves = 0, adopted = 0, waits = 0, late = 0, max_latency = 0;
};

nlohmann::json info(const Scene& s) {
  return nlohmann::json::parse(s.stats().model_info)["mass_spring"];
}

// The press on s in the one lock-step loop (paced: each step on a 1 ms tick), step times by
// TimedDevice (the Scene::step between the device's read and write).
Result run(Scene& s, const PressSpec& spec, bool paced) {
  Result r;
  s.reset();
  const auto before = info(s);
  PressDevice press(spec);
  std::vector<double> step_us;
  TimedDevice timed(press, step_us);
  int last_node = -1;
  long solves = 0, adopted = before.value("exterior_adopted", 0L);
  run_lockstep(s, timed, {.duration = spec.hold + 2.0, .frame_period = 0.0, .paced = paced},
               [&](const Rendered& out, const Sample&) {
                 const double us = step_us.back();
                 if (out.contact) r.us.push_back(us);
                 if (out.contact && us > 1000.0) ++r.over_1ms;
                 const auto now = info(s);  // outside the timed step
                 if (now.value("exterior_solves", 0L) > solves) r.move_us.push_back(us);
                 if (now.value("exterior_adopted", 0L) > adopted &&
                     now.value("exterior_update", "") != "sync")
                   r.adopt_us.push_back(us);
                 solves = now.value("exterior_solves", 0L);
                 adopted = now.value("exterior_adopted", 0L);
                 if (out.contact && last_node >= 0 && out.contact_node != last_node)
                   ++r.node_changes;
                 if (out.contact) last_node = out.contact_node;
                 r.force.push_back(out.force.norm());
               });
  const auto after = info(s);
  auto diff = [&](const char* k) { return after.value(k, 0L) - before.value(k, 0L); };
  r.moves = after.value("exterior_solves", 0L);  // since reset
  r.adopted = diff("exterior_adopted");
  r.waits = diff("exterior_waits");
  r.late = diff("exterior_late");
  r.max_latency = after.value("exterior_max_latency_steps", 0L);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  std::string dir = std::string(__FILE__);
  dir.resize(dir.rfind("/bench/"));
  dir += "/prototypes/";
  int reps = 5, latency = ScopeConfig{}.exterior_latency_steps;
  double speed = 0.02;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--reps" && i + 1 < argc)
      reps = std::atoi(argv[++i]);
    else if (a == "--speed" && i + 1 < argc)
      speed = std::atof(argv[++i]);
    else if (a == "--latency" && i + 1 < argc)
      latency = std::atoi(argv[++i]);
    else
      dir = a + "/";
  }
  const Mode modes[] = {
      {"sync", false, false}, {"deterministic", true, false}, {"async", true, true}};
  const PressSpec slide =
      sliding_press(prototypes::build_scene(dir + "C.json").geometry(), "ovary_left", 2.5, speed);
  std::printf(
      "prototype C, ovary_left: 2.5 N, then sliding at %.0f cm/s for %.2f s; exterior latency %d "
      "steps; %d reps, modes alternating; step times over the contact steps (us)\n",
      100 * speed, slide.hold, latency, reps);
  for (const bool paced : {false, true}) {
    // Fresh scenes per loop (the updater's counters are since construction).
    std::vector<Scene> scenes;
    for (const Mode& m : modes) {
      SceneConfig cfg = prototypes::load_prototype(dir + "C.json");
      cfg.scope.exterior_worker = m.worker;
      cfg.scope.exterior_latency_steps = latency;
      scenes.push_back(make_scene(cfg));
      scenes.back().set_realtime(m.realtime);
    }
    std::printf("\n%s\n", paced ? "1 kHz loop (each step on a 1 ms tick)"
                                : "lock-step loop (steps back to back)");
    std::printf("%-14s %9s %9s %9s %8s %6s %7s %6s %5s %8s %10s\n", "mode", "median", "p99", "max",
                "node chg", "moves", "adopted", "waits", "late", "lat max", "|dF| max");
    std::vector<Result> all(3);
    std::vector<double> dF(3, 0.0);
    for (int rep = 0; rep <= reps; ++rep) {  // rep 0 warms up
      std::vector<Result> now;
      for (int m = 0; m < 3; ++m) now.push_back(run(scenes[m], slide, paced));
      if (rep == 0) continue;
      for (int m = 0; m < 3; ++m) {
        Result& a = all[m];
        const Result& b = now[m];
        a.us.insert(a.us.end(), b.us.begin(), b.us.end());
        a.move_us.insert(a.move_us.end(), b.move_us.begin(), b.move_us.end());
        a.adopt_us.insert(a.adopt_us.end(), b.adopt_us.begin(), b.adopt_us.end());
        a.node_changes += b.node_changes, a.over_1ms += b.over_1ms, a.moves += b.moves,
            a.adopted += b.adopted, a.waits += b.waits, a.late += b.late;
        a.max_latency = std::max(a.max_latency, b.max_latency);
        for (size_t k = 0; k < std::min(b.force.size(), now[0].force.size()); ++k)
          dF[m] = std::max(dF[m], std::abs(b.force[k] - now[0].force[k]));
      }
    }
    for (int m = 0; m < 3; ++m) {
      const TimingSummary t = summarize_times(all[m].us);
      std::printf("%-14s %9.1f %9.1f %9.0f %8ld %6ld %7ld %6ld %5ld %8ld %9.4fN\n", modes[m].name,
                  t.median, t.p99, t.max, all[m].node_changes, all[m].moves, all[m].adopted,
                  all[m].waits, all[m].late, all[m].max_latency, dF[m]);
    }
    std::printf("%-14s %9s %9s %9s %9s %9s\n", "mode", ">1ms steps", "move med", "move max",
                "adopt med", "adopt max");
    for (int m = 0; m < 3; ++m) {
      const TimingSummary mv = summarize_times(all[m].move_us),
                          ad = summarize_times(all[m].adopt_us);
      std::printf("%-14s %9ld %9.0f %9.0f %9.0f %9.0f\n", modes[m].name, all[m].over_1ms, mv.median,
                  mv.max, ad.median, ad.max);
    }
  }
  return 0;
}
