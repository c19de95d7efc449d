// Throughput of the virtual-participant simulation (issue "virtual participants ... power
// analysis": exp2 is the unit of work of calibrate and power). Simulates participants of
// protocols/studies/exp2_short_term.json in memory (protocols::simulate_participant, what
// calibrate and power run; no database), one per group, with the training shortened to one
// 60 s session, and prints per group the median over repetitions of simulated seconds per wall
// second on one thread ("x real time"). A group's participant also runs sessions on other
// prototypes (exp2's post-training test is on A for every group), so a second table gives the
// rate per prototype the sessions ran on (each session's own wall time, summed over the
// repetitions): that is the rate to compare with a whole run's per-prototype session times.
// Run from the repository root, or set PALPLAB_SOURCE_DIR. The scene steps themselves are the
// engine's (bench_engine_step).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "protocols/plan.hpp"
#include "protocols/runner.hpp"
#include "protocols/study.hpp"

using namespace palplab::protocols;

int main(int argc, char** argv) {
  const char* src = std::getenv("PALPLAB_SOURCE_DIR");
  const std::string root = src ? src : ".";
  const std::string file = root + "/protocols/studies/exp2_short_term.json";
  // The prototypes of this tree, whatever the build recorded as its source path.
  if (!std::getenv("PALPLAB_PROTOTYPE_PATH"))
    setenv("PALPLAB_PROTOTYPE_PATH", (root + "/prototypes").c_str(), 1);
  Study study = load_study(file, engine_prototype_inspector());
  for (auto& ph : study.phases)
    if (ph.id == "training") ph.sessions = 1, ph.session_duration = 60.0;
  for (auto& g : study.groups) g.size = 1;
  const Plan plan = make_plan(study);
  const int reps = argc > 1 ? std::atoi(argv[1]) : 3;
  std::printf("%-6s %12s %14s %14s\n", "group", "simulated s", "median wall s", "x real time");
  std::map<std::string, std::pair<double, double>> per_prototype;  // simulated s, wall s
  for (const auto& pp : plan.participants) {
    double simulated = 0;
    for (const auto& s : pp.sessions) simulated += s.duration;
    std::vector<double> wall;
    for (int r = 0; r < reps; ++r) {
      const auto a = std::chrono::steady_clock::now();
      auto out = simulate_participant(study, pp);
      wall.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count());
      for (const auto& sd : out) {
        auto& [sim, w] = per_prototype[sd.session.prototype];
        sim += sd.session.duration;
        w += sd.session.wall_duration;
      }
    }
    std::sort(wall.begin(), wall.end());
    const double med = wall[wall.size() / 2];
    std::printf("%-6s %12.0f %14.3f %14.0f\n", pp.group.c_str(), simulated, med, simulated / med);
  }
  std::printf("\n%-9s %12s %12s %14s\n", "prototype", "simulated s", "wall s", "x real time");
  for (const auto& [id, sw] : per_prototype)
    std::printf("%-9s %12.0f %12.3f %14.0f\n", id.c_str(), sw.first, sw.second,
                sw.first / sw.second);
  return 0;
}
