#pragma once
// Sections of `palplab bench [SECTION...] [--quick] [--json FILE] [--md FILE]` (app/cmd_bench.cpp).
// A section registers itself with a static BenchSectionRegistration (one file per section,
// e.g. app/bench_section_stats.cpp) and returns its measurements; the command times nothing
// itself. Every measurement is the wall time of `reps` repetitions of one piece of work
// (reps >= 5): median, min, max in seconds, plus the first (cold) run separately, since
// caches (e.g. the studentized range tables) make later runs faster than a fresh process.
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace palplab::app {

struct BenchOptions {
  bool quick = false;    // fewer repetitions / smaller cases, for CI
  std::string data_dir;  // the repository's tests/data (NIST sets and other fixtures)
  std::string svg_dir;   // "" = no figures; else sections write <section>*.svg here
  // The repository's prototypes/ (data_dir/../../prototypes): sections build variants of them.
  std::string prototypes_dir() const;
};

struct BenchResult {
  std::string name, what;  // short id, human description
  int reps = 0;
  double median_s = 0, min_s = 0, max_s = 0, cold_s = 0;  // wall time
  // Process CPU time (every thread's, so it can exceed the wall time of parallel work): on a
  // shared machine wall time includes waiting for a core, CPU time does not.
  double median_cpu_s = 0;
  double cold_cpu_s = 0;  // CPU time of the cold run (0 where the section has none)
  double goal_s = 0;      // 0 = no stated goal
  // Further measured quantities of this case (errors, counts, ratios measured in the same run),
  // name -> value; the name carries the unit (e.g. "force_rel_err", "new_nodes", "ratio").
  std::vector<std::pair<std::string, double>> metrics;
};

// A result from per-repetition values already measured by the section (seconds per unit of
// work, e.g. per haptic step): median, min, max over `samples`; cold_s = the first run, which
// the caller measured separately (NaN-free: pass 0 when there was none). Medians and quantiles
// of sections: engine::median / engine::quantile (engine/haptics/clock.hpp), the one place.
BenchResult result_from_samples(const std::string& name, const std::string& what,
                                std::vector<double> samples_s, double cold_s = 0);

// Runs `work` once (cold) and then `reps` times; the median, min and max are over the reps.
BenchResult time_reps(const std::string& name, const std::string& what, int reps,
                      const std::function<void()>& work, double goal_s = 0);

using BenchSectionFn = std::function<std::vector<BenchResult>(const BenchOptions&)>;

struct BenchSection {
  std::string name, description;
  BenchSectionFn run;
};

std::vector<BenchSection>& bench_sections();

struct BenchSectionRegistration {
  BenchSectionRegistration(std::string name, std::string description, BenchSectionFn run);
};

}  // namespace palplab::app
