// `palplab bench stats`: wall time of the statistics as `palplab stats` runs them (CSV text →
// parse → group → full summary → text), on NIST SmLs09 (18 009 rows, 9 groups, 1e12 + 0.x:
// exact centring, p-values below 1e-300) and on 1e5 rows × 30 groups (435 pairs of Tukey,
// Games–Howell, Welch t with effect-size intervals); plus one far-tail studentized range
// p-value (q = 89.5, k = 9, ν = 4000, once 68 s). Goals from issue 11: SmLs09 <= 1 s,
// 1e5 × 30 <= 2 s (cold: a fresh process pays the one-time range tables).
#include <fstream>
#include <random>
#include <sstream>

#include "analysis/csv.hpp"
#include "analysis/distributions.hpp"
#include "analysis/grouped.hpp"
#include "analysis/summary.hpp"
#include "app/bench.hpp"
#include "common/input_error.hpp"

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

void full_stats(const std::string& csv) {
  CsvTable t = parse_csv(csv, "bench.csv");
  GroupedData d = group_table(t, "value", "group", {});
  StatsSummary s = summarize(d);
  volatile size_t sink = to_text(s).size();
  (void)sink;
}

palplab::app::BenchSectionRegistration reg{
    "stats", "palplab stats end to end (CSV text to tables) and the studentized range tail",
    [](const BenchOptions& o) {
      std::vector<BenchResult> r;
      const int reps = o.quick ? 5 : 9;
      const std::string smls09 = nist_csv(o.data_dir + "/nist/SmLs09.dat");
      r.push_back(palplab::app::time_reps(
          "smls09_full", "NIST SmLs09, 18009 rows x 9 groups", reps, [&] { full_stats(smls09); },
          1.0));
      const std::string big = generated_csv(100000, 30);
      r.push_back(palplab::app::time_reps(
          "rows1e5_groups30", "1e5 rows x 30 groups (435 pairs)", reps, [&] { full_stats(big); },
          2.0));
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
