// Planner: deterministic, balanced, derived seeds, the schedules of the original work.
#include <gtest/gtest.h>
#include <unistd.h>

#include <map>
#include <set>

#include "common/seed.hpp"
#include "protocols/plan.hpp"
#include "protocols/rng.hpp"
#include "study_fixture.hpp"

using namespace palplab;
using namespace palplab::protocols;

namespace {
Study load_ref(const std::string& f) {
  return load_study(fixture::study_in_dir("plan_" + f, fixture::reference_study(f)),
                    fixture::tract_inspector());
}
constexpr double kDay = 86400.0;
}  // namespace

TEST(Rng, KnownFirstValuesAndRanges) {
  // xoshiro256** is fully specified: the same seed gives the same stream everywhere.
  Rng a(42), b(42), c(43);
  std::uint64_t x = a.next();
  EXPECT_EQ(x, b.next());
  EXPECT_NE(x, c.next());
  Rng r(1);
  double sum = 0, sum2 = 0;
  const int n = 200000;
  std::vector<int> counts(7, 0);
  for (int i = 0; i < n; ++i) {
    double u = r.uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    counts[r.below(7)]++;
    double z = r.normal();
    sum += z;
    sum2 += z * z;
  }
  // mean 0 +- 4 SE, variance 1 +- 4 SE (SE of variance ~ sqrt(2/n))
  EXPECT_NEAR(sum / n, 0.0, 4.0 / std::sqrt(n));
  EXPECT_NEAR(sum2 / n, 1.0, 4.0 * std::sqrt(2.0 / n));
  for (int k : counts) EXPECT_NEAR(k, n / 7.0, 4.0 * std::sqrt(n / 7.0));
}

TEST(Plan, DeterministicAndSeedSensitive) {
  Study s = load_ref("exp2_short_term.json");
  Plan a = make_plan(s), b = make_plan(s);
  ASSERT_EQ(a.participants.size(), 30u);
  for (std::size_t i = 0; i < a.participants.size(); ++i) {
    EXPECT_EQ(a.participants[i].group, b.participants[i].group);
    EXPECT_EQ(a.participants[i].seed, b.participants[i].seed);
    for (std::size_t k = 0; k < a.participants[i].sessions.size(); ++k)
      EXPECT_EQ(a.participants[i].sessions[k].seed, b.participants[i].sessions[k].seed);
  }
  s.seed += 1;
  Plan c = make_plan(s);
  int differ = 0;
  for (std::size_t i = 0; i < a.participants.size(); ++i)
    differ += a.participants[i].group != c.participants[i].group;
  EXPECT_GT(differ, 0);  // another seed, another assignment
}

TEST(Plan, BalancedAssignmentAndDistinctSeeds) {
  Study s = load_ref("exp2_short_term.json");
  Plan p = make_plan(s);
  std::map<std::string, int> n;
  std::set<std::uint64_t> seeds;
  std::set<std::string> ids;
  for (const auto& pp : p.participants) {
    n[pp.group]++;
    ids.insert(pp.id);
    EXPECT_EQ(pp.seed, derive_seed(s.seed, label_hash("participant"),
                                   static_cast<std::uint64_t>(pp.number)));
    seeds.insert(pp.seed);
    for (const auto& ss : pp.sessions) seeds.insert(ss.seed);
  }
  EXPECT_EQ(n["A"], 10);
  EXPECT_EQ(n["B"], 10);
  EXPECT_EQ(n["C"], 10);
  EXPECT_EQ(ids.size(), 30u);
  EXPECT_EQ(seeds.size(), 30u + 30u * 6u);
  EXPECT_EQ(p.participants.front().id, "P01");
  EXPECT_EQ(p.participants.back().id, "P30");
}

TEST(Plan, ShortTermScheduleTenMinuteGaps) {
  Study s = load_ref("exp2_short_term.json");
  auto sl = schedule(s.phases);
  ASSERT_EQ(sl.size(), 6u);
  EXPECT_DOUBLE_EQ(sl[0].offset, 0.0);
  EXPECT_DOUBLE_EQ(sl[1].offset, 120.0 + 600.0);
  for (int k = 2; k <= 4; ++k) EXPECT_DOUBLE_EQ(sl[k].offset, sl[k - 1].offset + 300.0 + 600.0);
  EXPECT_DOUBLE_EQ(sl[5].offset, sl[4].offset + 300.0 + 600.0);
  EXPECT_DOUBLE_EQ(sl[5].duration, 120.0);
  for (auto& x : sl) EXPECT_EQ(x.day, 0);
  // post-training on the haptic-only simulator for every group
  Plan p = make_plan(s);
  for (const auto& pp : p.participants) {
    EXPECT_EQ(pp.sessions[5].prototype, "A");
    EXPECT_EQ(pp.sessions[5].cues.audio, std::optional<bool>(false));
    EXPECT_EQ(pp.sessions[5].cues.visual_deformation, std::optional<bool>(false));
    EXPECT_EQ(pp.sessions[2].prototype, pp.group);
  }
}

TEST(Plan, LongTermScheduleDaysOneToFourAndSeven) {
  Study s = load_ref("exp3_long_term.json");
  Plan p = make_plan(s);
  ASSERT_EQ(p.participants.size(), 24u);
  for (const auto& pp : p.participants) {
    ASSERT_EQ(pp.sessions.size(), 6u);
    EXPECT_EQ(pp.sessions[0].phase_id, "pre_training");
    EXPECT_EQ(pp.sessions[0].day, 0);
    for (int k = 1; k <= 4; ++k) {
      EXPECT_EQ(pp.sessions[k].phase_id, "training");
      EXPECT_EQ(pp.sessions[k].day, k);
      EXPECT_DOUBLE_EQ(pp.sessions[k].offset, k * kDay);
    }
    EXPECT_EQ(pp.sessions[5].phase_id, "post_training");
    EXPECT_EQ(pp.sessions[5].day, 7);
    EXPECT_DOUBLE_EQ(pp.sessions[5].offset, 7 * kDay);
  }
}

TEST(Plan, InstructorTableOfExperimentOne) {
  Study s = load_ref("exp1_instructor.json");
  Plan p = make_plan(s);
  std::map<std::string, std::vector<std::string>> expected = {{"A", {"I1", "I2", "I3", "I4"}},
                                                              {"B", {"I9", "I10", "I3", "I6"}},
                                                              {"C", {"I5", "I6", "I7", "I8"}}};
  for (const auto& pp : p.participants) {
    ASSERT_EQ(pp.sessions.size(), 4u);
    for (int k = 0; k < 4; ++k) EXPECT_EQ(pp.sessions[k].instructor, expected[pp.group][k]);
  }
}

TEST(Plan, ExplicitAssignmentKeepsIds) {
  std::string text = R"({"palplab_study": 1, "id": "x", "title": "x", "seed": 3,
    "task": {"feature": "ovary_left", "thresholds": {"*": {"ST": 1, "MPF": 2, "SFT": 3}}},
    "assignment": "explicit",
    "groups": [{"id": "G1", "prototype": "A", "participants": ["s7", "s3"]},
               {"id": "G2", "prototype": "B", "participants": ["s1"]}],
    "phases": [{"id": "t", "kind": "training", "session_duration": 10}]})";
  Study s = load_study(fixture::study_in_dir("explicit", text), fixture::tract_inspector());
  Plan p = make_plan(s);
  ASSERT_EQ(p.participants.size(), 3u);
  EXPECT_EQ(p.participants[0].id, "s7");
  EXPECT_EQ(p.participants[1].id, "s3");
  EXPECT_EQ(p.participants[2].id, "s1");
  EXPECT_EQ(p.participants[2].group, "G2");
  EXPECT_EQ(p.participants[2].sessions[0].prototype, "B");
}

TEST(Plan, SummaryMentionsTimeline) {
  Study s = load_ref("exp3_long_term.json");
  std::string sum = plan_summary(s, make_plan(s));
  EXPECT_NE(sum.find("24 participants"), std::string::npos);
  EXPECT_NE(sum.find("day 7 +00:00:00  post_training #1"), std::string::npos) << sum;
  EXPECT_NE(sum.find("day 4 +00:00:00  training #4"), std::string::npos) << sum;
}
