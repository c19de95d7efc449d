// Session measures from a hand-built log with known answers.
#include <gtest/gtest.h>

#include <cmath>

#include "protocols/measures.hpp"
#include "results/measure_kind.hpp"

using namespace palplab;
using namespace palplab::protocols;

namespace {
// Samples at 1 kHz for `seconds`; node/force set per interval by the test.
results::SampleSeries blank(double seconds) {
  results::SampleSeries s;
  s.dt = 0.001;
  const std::size_t n = static_cast<std::size_t>(std::lround(seconds / s.dt));
  s.x.assign(3 * n, 0.0);
  s.F.assign(3 * n, 0.0);
  s.node.assign(n, -1);
  return s;
}
// Contact on `node` for steps [a, b) with a triangular force profile peaking at `peak` (N).
void touch(results::SampleSeries& s, std::size_t a, std::size_t b, int node, double peak) {
  for (std::size_t i = a; i < b; ++i) {
    double u = static_cast<double>(i - a) / (b - a - 1);
    s.node[i] = node;
    s.F[3 * i + 2] = peak * (1.0 - std::abs(2.0 * u - 1.0));
  }
}
}  // namespace

TEST(Measures, KnownLog) {
  // nodes 0..1 are the feature (region 0), node 2 elsewhere (region 1)
  std::vector<int> region = {0, 0, 1};
  auto s = blank(10.0);
  touch(s, 200, 400, 2, 1.0);      // elsewhere: not identification
  touch(s, 1000, 1300, 0, 0.2);    // on the feature 0.3 s: identified at t = 1.2 s
  touch(s, 2000, 2500, 1, 2.6);    // palpation, accurate (|2.6 - 2.5| <= 0.25)
  touch(s, 3000, 3500, 1, 3.0);    // palpation, not accurate
  touch(s, 4000, 4100, 1, 0.3);    // below the onset: not a palpation
  touch(s, 9800, 10000, 1, 2.45);  // still in contact at the end: counts, accurate
  std::vector<results::EventRecord> ev = {{3.2, "sft_reached", 3.0, "ovary_left"},
                                          {3.1, "st_reached", 2.3, "ovary_left"}};
  MeasureInputs in;
  in.samples = &s;
  in.events = &ev;
  in.vertex_region = &region;
  in.feature_region = 0;
  in.mpf = 2.5;
  in.accuracy_tolerance = 0.25;
  in.identify_dwell = 0.2;
  in.palpation_onset = 0.5;
  auto m = compute_measures(in);
  auto get = [&](const std::string& n) {
    for (auto& r : m)
      if (r.name == n) return r;
    ADD_FAILURE() << n;
    return results::MeasureRecord{};
  };
  EXPECT_NEAR(*get("exploration_time").value, 1.2, 1e-9);
  EXPECT_EQ(get("exploration_time").unit, "s");
  EXPECT_EQ(*get("feature_identified").value, 1.0);
  // peak of the triangular profile is reached within one step of the nominal peak
  EXPECT_NEAR(*get("palpation_force").value, 3.0, 3.0 * 2.0 / 499);
  EXPECT_EQ(get("palpation_force").unit, "N");
  EXPECT_EQ(*get("palpations").value, 3.0);
  EXPECT_NEAR(*get("accuracy").value, 100.0 * 2.0 / 3.0, 1e-9);
  EXPECT_EQ(get("accuracy").unit, "%");
  EXPECT_EQ(*get("sft_reached").value, 1.0);
}

TEST(Measures, NotIdentifiedLeavesForceUndefined) {
  std::vector<int> region = {0, 1};
  auto s = blank(2.0);
  touch(s, 100, 250, 0, 0.4);  // 0.15 s on the feature: shorter than the dwell
  touch(s, 500, 900, 1, 4.0);  // a hard press elsewhere
  MeasureInputs in;
  in.samples = &s;
  in.vertex_region = &region;
  in.feature_region = 0;
  in.mpf = 2.5;
  auto m = compute_measures(in);
  EXPECT_EQ(m[0].name, "palpation_force");
  EXPECT_FALSE(m[0].value.has_value());
  EXPECT_FALSE(m[1].value.has_value());  // exploration_time
  EXPECT_EQ(*m[2].value, 0.0);           // feature_identified
  EXPECT_FALSE(m[3].value.has_value());  // accuracy
}

// What the sessions store is what results::kMeasureKinds (the validator's, the store's and the
// report's one table) says: every name in it with its unit and task, each of a task's rows once.
TEST(Measures, EveryComputedMeasureIsInTheTableWithItsUnit) {
  std::vector<int> region = {0, 1};
  auto s = blank(2.0);
  touch(s, 100, 900, 0, 3.0);
  MeasureInputs in;
  in.samples = &s;
  in.vertex_region = &region;
  in.feature_region = 0;
  in.mpf = 2.5;
  const std::vector<results::EventRecord> none;
  for (const auto& [task, computed] :
       {std::pair{std::string("palpation"), compute_measures(in)},
        std::pair{std::string("needle_insertion"), compute_needle_measures(none)}}) {
    std::size_t rows = 0;
    for (const auto& k : results::kMeasureKinds) rows += k.task == task;
    EXPECT_EQ(computed.size(), rows) << task;
    for (const auto& m : computed) {
      const results::MeasureKind* k = results::find_measure_kind(m.name);
      ASSERT_NE(k, nullptr) << m.name;
      EXPECT_EQ(k->unit, m.unit) << m.name;
      EXPECT_EQ(k->task, task) << m.name;
      if (m.value) {
        EXPECT_LE(*m.value, k->hi) << m.name;
      }
    }
  }
}
