// `palplab bench stats`: wall time of the statistics as `palplab stats` runs them (CSV text →
// parse → group → full summary → text), on NIST SmLs09 (18 009 rows, 9 groups, 1e12 + 0.x:
// exact centring, p-values below 1e-300) and on 1e5 rows × 30 groups (435 pairs of Tukey,
// Games–Howell, Welch t with effect-size intervals); plus one far-tail studentized range
// p-value (q = 89.5, k = 9, ν = 4000, once 68 s). Goals from issue 11: SmLs09 <= 1 s,
// 1e5 × 30 <= 2 s cold. "Cold" in the in-process cases is their first repetition (it builds
// the k = 30 range table; SmLs09's k = 9 table is built by its own first run); the goal's
// case proper is `rows1e5_groups30_process`: `palplab stats` on the same rows written to a
// CSV file, each repetition a fresh process (posix_spawn of this executable; wall time from
// spawn to exit, CPU time = the child's user + system time from wait4), so every run pays
// process start, file reading and the one-time tables.
#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "analysis/csv.hpp"
#include "analysis/distributions.hpp"
#include "analysis/grouped.hpp"
#include "analysis/summary.hpp"
#include "app/bench.hpp"
#include "common/input_error.hpp"
#include "engine/haptics/clock.hpp"

namespace {
using namespace palplab::analysis;
using palplab::app::BenchOptions;
using palplab::app::BenchResult;

std::string nist_csv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw palplab::InputError("cannot read the NIST data set", path);
  std::string line, csv = "group,value\n";
  int n = 0;
  while (std::getline(in, line)) {
    if (++n <= 60) continue;  // the StRD header
    std::istringstream ss(line);
    std::string g, v;
    if (ss >> g >> v) csv += g + "," + v + "\n";
  }
  return csv;
}

std::string generated_csv(int rows, int groups) {
  std::mt19937_64 rng(20261124);
  std::normal_distribution<double> n01(0, 1);
  std::string csv = "group,value\n";
  char b[64];
  for (int i = 0; i < rows; ++i) {
    int g = i % groups;
    std::snprintf(b, sizeof b, "G%02d,%.4f\n", g, 10 + 0.05 * g + (1 + 0.02 * g) * n01(rng));
    csv += b;
  }
  return csv;
}

struct ProcessRun {
  double wall_s = 0, cpu_s = 0;
};

// `palplab stats --csv FILE --value value --group group` as a fresh process, its output to
// /dev/null; a failed run (non-zero exit) is an error of the benchmark.
ProcessRun stats_process(const std::string& csv_path) {
  const std::string exe = std::filesystem::read_symlink("/proc/self/exe").string();
  std::vector<std::string> args = {exe,       "stats", "--csv",   csv_path,
                                   "--value", "value", "--group", "group"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  const auto t0 = std::chrono::steady_clock::now();
  pid_t pid = 0;
  const int err = posix_spawn(&pid, exe.c_str(), &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (err != 0) throw std::runtime_error("bench stats: cannot start " + exe);
  int status = 0;
  struct rusage ru {};
  if (wait4(pid, &status, 0, &ru) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error("bench stats: `palplab stats` on " + csv_path + " failed");
  ProcessRun r;
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.cpu_s = static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
            1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
  return r;
}

void full_stats(const std::string& csv) {
  CsvTable t = parse_csv(csv, "bench.csv");
  GroupedData d = group_table(t, "value", "group", {});
  StatsSummary s = summarize(d);
  volatile size_t sink = to_text(s).size();
  (void)sink;
}

palplab::app::BenchSectionRegistration section_stats{
    "stats", "palplab stats end to end (CSV text to tables) and the studentized range tail",
    [](const BenchOptions& o) {
      std::vector<BenchResult> r;
      const int reps = o.quick ? 5 : 9;
      const std::string smls09 = nist_csv(o.data_dir + "/nist/SmLs09.dat");
      r.push_back(palplab::app::time_reps(
          "smls09_full", "NIST SmLs09, 18009 rows x 9 groups", reps, [&] { full_stats(smls09); },
          1.0));
      const std::string big = generated_csv(100000, 30);
      // --quick (CI) measures the 1e5-row case once, as the goal states it (fresh processes);
      // the full run also times it in this process.
      if (!o.quick)
        r.push_back(palplab::app::time_reps(
            "rows1e5_groups30", "1e5 rows x 30 groups (435 pairs)", reps, [&] { full_stats(big); },
            2.0));
      {
        // The goal's case: a fresh process per repetition (see the top of this file).
        const auto dir = std::filesystem::temp_directory_path() /
                         ("palplab_bench_stats_" + std::to_string(static_cast<long>(::getpid())));
        std::filesystem::create_directories(dir);
        const std::string path = (dir / "rows1e5_groups30.csv").string();
        {
          std::ofstream out(path, std::ios::binary);
          out << big;
          if (!out) throw palplab::InputError("cannot write the benchmark's CSV file", path);
        }
        std::vector<double> wall, cpu;
        ProcessRun cold{};
        for (int i = 0; i <= reps; ++i) {
          const ProcessRun p = stats_process(path);
          if (i == 0) {
            cold = p;
            continue;
          }
          wall.push_back(p.wall_s);
          cpu.push_back(p.cpu_s);
        }
        std::filesystem::remove_all(dir);
        BenchResult b = palplab::app::result_from_samples(
            "rows1e5_groups30_process",
            "palplab stats on a 1e5 rows x 30 groups CSV file, a fresh process per run", wall,
            cold.wall_s);
        b.median_cpu_s = palplab::engine::median(cpu);
        b.cold_cpu_s = cold.cpu_s;
        b.goal_s = 2.0;
        r.push_back(b);
      }
      r.push_back(palplab::app::time_reps("srange_far_tail",
                                          "P(Q > 89.5), k = 9, df = 4000 (below 1e-300)", reps, [] {
                                            volatile double p = studentized_range_sf(89.5, 9, 4000);
                                            (void)p;
                                          }));
      r.push_back(palplab::app::time_reps("srange_tail_1e253",
                                          "P(Q > 52), k = 9, df = 4000 (1.1e-253)", reps, [] {
                                            volatile double p = studentized_range_sf(52, 9, 4000);
                                            (void)p;
                                          }));
      return r;
    }};
}  // namespace
