// `palplab bench throughput`: `palplab run` of exp2 (protocols/studies/exp2_short_term.json)
// with virtual participants at --jobs 1 and --jobs 2, into a fresh SQLite database with every
// 1 kHz sample stored (the default of `run`). The study is shortened so that a repetition is
// short: one session per phase of 5 s (--quick; 30 s in the full run), 1 participant per
// group (--quick; 2 in the full run), i.e. 3 (6) participants on prototypes A, B and C.
// Per jobs: wall time of the run (median of 5 repetitions), simulated seconds per wall second,
// the process's peak resident memory during the run (VmHWM after resetting it through
// /proc/self/clear_refs; 0 where the kernel does not allow the reset) and the database bytes per
// simulated second. The jobs-2 / jobs-1 speed-up is measured in the same run.
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>

#include "app/bench.hpp"
#include "app/bench_scene.hpp"
#include "engine/haptics/clock.hpp"
#include "protocols/plan.hpp"
#include "protocols/runner.hpp"
#include "protocols/study.hpp"

namespace {
using namespace palplab;
using palplab::app::BenchOptions;
using palplab::app::BenchResult;

// Peak resident set (bytes) since the last reset; resets it again for the next measurement.
double take_peak_rss() {
  double kb = 0;
  std::ifstream st("/proc/self/status");
  std::string key;
  while (st >> key) {
    if (key == "VmHWM:") {
      st >> kb;
      break;
    }
    std::getline(st, key);
  }
  std::ofstream("/proc/self/clear_refs") << "5";
  return kb * 1024.0;
}

std::vector<BenchResult> run_throughput(const BenchOptions& o) {
  const std::string root =
      (std::filesystem::path(o.data_dir) / ".." / "..").lexically_normal().string();
  if (!std::getenv("PALPLAB_PROTOTYPE_PATH"))
    setenv("PALPLAB_PROTOTYPE_PATH", o.prototypes_dir().c_str(), 1);
  protocols::Study study = protocols::load_study(root + "/protocols/studies/exp2_short_term.json",
                                                 protocols::engine_prototype_inspector());
  for (auto& ph : study.phases) ph.sessions = 1, ph.session_duration = o.quick ? 5.0 : 30.0;
  for (auto& g : study.groups) g.size = o.quick ? 1 : 2;
  const protocols::Plan plan = protocols::make_plan(study);
  const auto& dir = palplab::app::bench_scratch_dir();
  const int reps = 5;
  std::vector<BenchResult> out;
  std::vector<double> med;
  for (int jobs : {1, 2}) {
    const std::string db = (dir / ("throughput_j" + std::to_string(jobs) + ".db")).string();
    std::vector<double> wall, cpu;
    double simulated = 0, bytes = 0, peak = 0, cold = 0, cold_cpu = 0;
    take_peak_rss();
    for (int rep = 0; rep <= reps; ++rep) {
      protocols::RunOptions ro;
      ro.db = db;
      ro.jobs = jobs;
      ro.force = true;
      const auto t0 = std::chrono::steady_clock::now();
      const std::clock_t c0 = std::clock();  // the process's CPU time: every job's thread
      const protocols::RunSummary s = protocols::run_study(study, plan, ro);
      const double w = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const double c = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
      if (!s.complete) throw std::runtime_error("throughput: the run did not complete");
      simulated = s.simulated;
      bytes = static_cast<double>(std::filesystem::file_size(db));
      peak = std::max(peak, take_peak_rss());
      if (rep == 0) {
        cold = w;
        cold_cpu = c;
      } else {
        wall.push_back(w);
        cpu.push_back(c);
      }
    }
    std::filesystem::remove(db);
    BenchResult r = app::result_from_samples(
        "exp2_jobs" + std::to_string(jobs),
        "palplab run exp2 (" + std::to_string(plan.participants.size()) +
            " participants, samples stored), --jobs " + std::to_string(jobs) + " (s per run)",
        wall, cold);
    r.median_cpu_s = engine::median(cpu);
    r.cold_cpu_s = cold_cpu;
    med.push_back(r.median_s);
    r.metrics = {{"simulated_s", simulated},
                 {"x_real_time", simulated / r.median_s},
                 {"peak_rss_bytes", peak},
                 {"db_bytes", bytes},
                 {"db_bytes_per_simulated_s", bytes / simulated},
                 {"speedup_over_jobs1", med.front() / r.median_s}};
    out.push_back(r);
  }
  return out;
}

palplab::app::BenchSectionRegistration section_throughput{
    "throughput",
    "exp2 with virtual participants: simulated s per wall s at --jobs 1 and 2, peak memory, "
    "database bytes per simulated s",
    run_throughput};
}  // namespace
