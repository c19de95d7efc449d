// People's verdicts on a study's declared tests and their reproducibility (`palplab power
// --human`): the verdicts are those of the analysis functions on the people's values, the
// resampled study keeps each group's participants (a p near alpha replicates about half the
// time, a tiny p nearly always), and power_summary counts the replicates that agree.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/anova.hpp"
#include "analysis/descriptives.hpp"
#include "analysis/two_sample.hpp"
#include "common/input_error.hpp"
#include "protocols/calibrate.hpp"
#include "protocols/people_verdicts.hpp"
#include "protocols/power.hpp"
#include "protocols/study.hpp"

using namespace palplab::protocols;
namespace fs = std::filesystem;

namespace {

const fs::path kSource = PALPLAB_SOURCE_DIR;

Study exp2() {
  return load_study((kSource / "protocols" / "studies" / "exp2_short_term.json").string(),
                    engine_prototype_inspector());
}

std::string human_csv() {
  return (kSource / "tests/data/calibration/exp2_human.csv").string();
}

// The people's values per measure and group, read here with a plain parser (not
// read_human_cells): participant,group,phase,session,measure,value[,unit].
std::map<std::string, std::map<std::string, std::vector<double>>> plain_values() {
  std::map<std::string, std::map<std::string, std::vector<double>>> out;
  std::ifstream in(human_csv());
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::vector<std::string> f;
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    out[f[4]][f[1]].push_back(std::stod(f[5]));
  }
  return out;
}

const TestOutcome& find(const std::vector<TestOutcome>& tests, const std::string& id) {
  for (const auto& t : tests)
    if (t.id == id) return t;
  throw std::runtime_error("no test " + id);
}

fs::path scratch(const std::string& name) {
  auto d = fs::temp_directory_path() / ("palplab_people_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

}  // namespace

TEST(PeopleVerdicts, AreTheAnalysesOfThePeoplesValues) {
  const Study study = exp2();
  const PeopleVerdicts v = people_verdicts(study, read_human_cells(human_csv()), 0.05, {10}, 10);
  const auto values = plain_values();
  // Every declared test: 2 ANOVAs and 3 pairs per measure.
  ASSERT_EQ(v.tests.size(), 8u);
  for (const std::string m : {"palpation_force", "exploration_time"}) {
    const auto& g = values.at(m);
    const auto anova = palplab::analysis::oneway_anova({g.at("A"), g.at("B"), g.at("C")});
    EXPECT_DOUBLE_EQ(find(v.tests, "anova_oneway " + m + " post_training").p, anova.p) << m;
    for (const auto& [a, b] : {std::pair{"A", "B"}, {"A", "C"}, {"B", "C"}}) {
      const std::string id = "pairwise_t " + m + " post_training " + a + "-" + b;
      const auto w = palplab::analysis::welch_t(g.at(a), g.at(b));
      EXPECT_DOUBLE_EQ(find(v.tests, id).p, w.p) << id;
      EXPECT_DOUBLE_EQ(find(v.tests, id).effect, palplab::analysis::cohens_d(g.at(a), g.at(b)).g)
          << id;
    }
  }
  // The published pattern (docs/PARTICIPANTS.md): force B - C p = .046, time B - C p = .114.
  EXPECT_NEAR(find(v.tests, "pairwise_t palpation_force post_training B-C").p, 0.046, 0.001);
  EXPECT_NEAR(find(v.tests, "pairwise_t exploration_time post_training B-C").p, 0.114, 0.001);
  EXPECT_EQ(v.n.at("A"), 10);
  EXPECT_EQ(v.n.at("C"), 10);
}

TEST(PeopleVerdicts, ARightModelsDrawsHoldBothStudiesSamplingErrors) {
  // A right model's replicate and the people's study are two samples of one truth, drawn here
  // independently from the people's participants. A verdict the people reached with p near
  // alpha is then reached by the other study about half the time (Goodman 1992; Killeen 2005),
  // one with p = 7e-5 nearly always; at a large n the replicate is nearly always significant, so
  // it agrees only as often as the people's own study is: about half the time for B - C. A
  // group mean falls inside the people's 95 % t interval about 86 % of the time at equal
  // n = 10 (normal data: P(|t9| < t9,.975 / sqrt 2); 83 % for a z interval, Cumming &
  // Maillardet 2006) and towards 95 % for a large n. The review of 2026-12-05 found the first
  // version (the people's study drawn again, the replicate drawn from that, compared with the
  // observed interval) at 0.91-0.93; drawing only the people's study gave 0.98.
  const PeopleVerdicts v =
      people_verdicts(exp2(), read_human_cells(human_csv()), 0.05, {10, 100}, 2000);
  EXPECT_EQ(v.resamples, 2000);
  const RightModel& m = v.right.at(10);
  const double bc = m.agree.at("pairwise_t palpation_force post_training B-C") / 2000.0;
  EXPECT_GT(bc, 0.35);
  EXPECT_LT(bc, 0.70);
  EXPECT_GT(m.agree.at("pairwise_t palpation_force post_training A-C") / 2000.0, 0.9);
  // At n = 100 the replicate finds the B - C force difference nearly always, the people's study
  // about half the time: they agree about half the time.
  const double bc100 =
      v.right.at(100).agree.at("pairwise_t palpation_force post_training B-C") / 2000.0;
  EXPECT_GT(bc100, 0.35);
  EXPECT_LT(bc100, 0.75);
  EXPECT_GT(v.right.at(100).agree.at("pairwise_t palpation_force post_training A-C") / 2000.0, 0.9);
  // All eight together: at most the least reproducible one.
  EXPECT_LE(m.all_agree, m.agree.at("pairwise_t palpation_force post_training B-C"));
  EXPECT_GT(m.all_agree, 0);
  EXPECT_GE(m.median_agreeing, 6.0);
  EXPECT_LE(m.median_agreeing, 8.0);
  for (const auto& g : v.groups) {
    const std::string key = g.cell + "\t" + g.group;
    const double at10 = m.inside.at(key) / 2000.0, at100 = v.right.at(100).inside.at(key) / 2000.0;
    EXPECT_GT(at10, 0.78) << key;
    EXPECT_LT(at10, 0.91) << key;
    EXPECT_GT(at100, at10 + 0.03) << key;
    EXPECT_GT(at100, 0.9) << key;
  }
  // Six means inside together: fewer. The people's force order A > B > C holds unless B and C
  // swap (B - C p = .046), their exploration order A > B > C unless B and C swap (p = .114,
  // more often).
  EXPECT_LT(m.all_inside / 2000.0, 0.7);
  EXPECT_GT(m.all_inside / 2000.0, 0.2);
  const double force_order = m.same_order.at("palpation_force post_training") / 2000.0;
  const double time_order = m.same_order.at("exploration_time post_training") / 2000.0;
  EXPECT_GT(force_order, 0.75);
  EXPECT_LT(time_order, force_order);
  EXPECT_GT(time_order, 0.6);
  EXPECT_LE(m.all_orders, m.same_order.at("exploration_time post_training"));
  EXPECT_LE(m.pattern, std::min({m.all_agree, m.all_orders, m.all_inside}));
  EXPECT_GT(m.pattern, 0);
  // The people's group descriptives are those of their values.
  const auto values = plain_values();
  ASSERT_EQ(v.groups.size(), 6u);
  for (const auto& g : v.groups) {
    const std::string measure = g.cell.substr(0, g.cell.find(' '));
    const auto d = palplab::analysis::describe(values.at(measure).at(g.group));
    EXPECT_EQ(g.n, 10);
    EXPECT_DOUBLE_EQ(g.mean, d.mean) << g.cell << " " << g.group;
    EXPECT_DOUBLE_EQ(g.sd, d.sd) << g.cell << " " << g.group;
    EXPECT_DOUBLE_EQ(g.ci_low, d.ci_low) << g.cell << " " << g.group;
  }
  EXPECT_EQ(order_of_means(v.groups, "palpation_force post_training"), "A > B > C");
  EXPECT_EQ(order_of_means(v.groups, "exploration_time post_training"), "A > B > C");
  // Seeded from the study: the same numbers again.
  const PeopleVerdicts again =
      people_verdicts(exp2(), read_human_cells(human_csv()), 0.05, {10}, 2000);
  EXPECT_EQ(again.right.at(10).all_agree, m.all_agree);
  EXPECT_EQ(again.right.at(10).pattern, m.pattern);
}

TEST(PeopleVerdicts, DataThatCannotBeTestedAreInputErrors) {
  const Study study = exp2();
  const auto d = scratch("bad");
  auto expect_error = [&](const std::string& name, const std::string& text,
                          const std::string& needle) {
    const std::string path = (d / name).string();
    std::ofstream(path) << "participant,group,phase,session,measure,value\n" << text;
    try {
      people_verdicts(study, read_human_cells(path), 0.05, {10}, 10);
      ADD_FAILURE() << name << ": no error";
    } catch (const palplab::InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(needle), std::string::npos) << name << ": " << what;
      EXPECT_NE(what.find(path), std::string::npos) << name << ": " << what;
    }
  };
  std::string ok;  // two people per group, both measures
  for (const char* g : {"A", "B", "C"})
    for (int k = 1; k <= 2; ++k)
      for (const char* m : {"palpation_force", "exploration_time"})
        ok += std::string(g) + std::to_string(k) + "," + g + ",post_training,1," + m + "," +
              std::to_string(2.0 + k) + "\n";
  // Rows of cells the study does not simulate (review 2026-12-04: a session 2 replaced the
  // tested values, a misspelt phase or a blank after it left a value out, all silently).
  expect_error("unknown_group.csv", ok + "Z1,Z,post_training,1,palpation_force,2.5\n",
               "group \"Z\" (the study's groups: A, B, C)");
  expect_error("session2.csv", ok + "A1,A,post_training,2,palpation_force,9\n",
               "session 2 of phase post_training (it has 1 session)");
  expect_error("phase_typo.csv", ok + "A3,A,post_trainnig,1,palpation_force,2.5\n",
               "phase \"post_trainnig\"");
  expect_error("phase_blank.csv", ok + "A3,A,post_training ,1,palpation_force,2.5\n",
               "phase \"post_training \"");
  expect_error("measure_typo.csv", ok + "A3,A,post_training,1,palpation_forse,2.5\n",
               "\"palpation_forse\" is not a measure the study");
  // An id with a blank is the same participant: given twice, or in two groups.
  expect_error("blank_id.csv", ok + "A1 ,A,post_training,1,palpation_force,9\n", "given twice");
  expect_error("blank_id_group.csv", ok + "A1\t,B,post_training,1,palpation_force,9\n",
               "is in group \"B\" here but in group \"A\"");
  // No variance anywhere: no test has a verdict.
  std::string flat;
  for (const char* g : {"A", "B", "C"})
    for (int k = 1; k <= 2; ++k)
      for (const char* m : {"palpation_force", "exploration_time"})
        flat += std::string(g) + std::to_string(k) + "," + g + ",post_training,1," + m + ",2\n";
  expect_error("flat.csv", flat, "none of the study's tests is defined on the people's data");
  // Group C with one force value only.
  std::string one_c;
  for (const char* g : {"A", "B", "C"})
    for (int k = 1; k <= (g[0] == 'C' ? 1 : 2); ++k)
      one_c += std::string(g) + std::to_string(k) + "," + g +
               ",post_training,1,palpation_force,2." + std::to_string(k) + "\n";
  expect_error("one_value.csv", one_c, "group C has 1 value of palpation_force");
  // Only the force: the exploration time's tests have nothing to test.
  std::string force_only;
  for (const char* g : {"A", "B", "C"})
    for (int k = 1; k <= 2; ++k)
      force_only += std::string(g) + std::to_string(k) + "," + g +
                    ",post_training,1,palpation_force,2." + std::to_string(k) + "\n";
  expect_error("force_only.csv", force_only,
               "no values of exploration_time in phase post_training");
  fs::remove_all(d);
}

TEST(PeopleVerdicts, TheSummaryCountsReplicatesThatReachThePeoplesVerdicts) {
  // Four replicates of a study with two tests; people: T1 significant, T2 not.
  const auto d = scratch("summary");
  const std::string file = (d / "replicates.jsonl").string();
  {
    std::ofstream o(file);
    const double p1[4] = {0.01, 0.2, 0.001, NAN}, p2[4] = {0.5, 0.01, 0.3, 0.9};
    for (int r = 0; r < 4; ++r) {
      nlohmann::json rec = {{"n", 5},
                            {"replicate", r},
                            {"seed", r + 1},
                            {"study", "s"},
                            {"study_sha256", std::string(64, 'a')},
                            {"tests", nlohmann::json::array()}};
      auto test = [](const char* id, double p) {
        return nlohmann::json{{"id", id},
                              {"p", std::isfinite(p) ? nlohmann::json(p) : nlohmann::json()},
                              {"effect", 0.5},
                              {"effect_name", "hedges_g"}};
      };
      rec["tests"].push_back(test("T1", p1[r]));
      rec["tests"].push_back(test("T2", p2[r]));
      o << rec.dump() << "\n";
    }
  }
  PeopleVerdicts people;
  people.file = "people.csv";
  people.tests = {{"T1", 0.003, 1.2, "hedges_g"}, {"T2", 0.3, 0.2, "hedges_g"}};
  people.n = {{"G1", 5}, {"G2", 5}};
  people.resamples = 10;
  people.right[5].agree = {{"T1", 9}, {"T2", 6}};
  people.right[5].all_agree = 5;
  people.right[5].median_agreeing = 1.5;
  const auto s = power_summary({file}, 0.05, 0.8, {}, nullptr, &people);
  // T1 agrees in replicates 0 and 2 (the undefined one counts as not significant), T2 in 0, 2, 3.
  for (const auto& t : s.at("tests")) {
    const bool t1 = t.at("id") == "T1";
    EXPECT_EQ(t.at("by_n")[0].at("agree").get<long>(), t1 ? 2 : 3);
    EXPECT_EQ(t.at("people").at("significant").get<bool>(), t1);
  }
  const auto& p = s.at("people");
  EXPECT_EQ(p.at("by_n")[0].at("all_agree").get<long>(), 2);  // replicates 0 and 2
  // Agreeing per replicate: 2, 0, 2, 1 -> median 1.5.
  EXPECT_DOUBLE_EQ(p.at("by_n")[0].at("median_agreeing").get<double>(), 1.5);
  EXPECT_DOUBLE_EQ(p.at("by_n")[0].at("right_model").at("all_agree").get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(s.at("tests")[0].at("by_n")[0].at("right_model").get<double>(), 0.9);
  EXPECT_FALSE(s.contains("groups"));  // records without group descriptives
  // A people's test undefined on their data has no verdict: not compared, not counted.
  PeopleVerdicts half = people;
  half.tests[1].p = NAN;
  half.right[5].agree.erase("T2");
  const auto h = power_summary({file}, 0.05, 0.8, {}, nullptr, &half);
  for (const auto& t : h.at("tests")) {
    const bool t1 = t.at("id") == "T1";
    EXPECT_EQ(t.at("people").at("significant").is_null(), !t1);
    EXPECT_EQ(t.at("by_n")[0].at("agree").is_null(), !t1);
  }
  EXPECT_EQ(h.at("people").at("tests").get<int>(), 1);
  EXPECT_EQ(h.at("people").at("by_n")[0].at("all_agree").get<long>(), 2);  // T1 alone: 0 and 2
  EXPECT_TRUE(h.at("tests")[1].at("by_n")[0].at("right_model").is_null());
  // A people's test the replicates do not have: another version of the study.
  people.tests.push_back({"T3", 0.5, 0.0, "hedges_g"});
  EXPECT_THROW(power_summary({file}, 0.05, 0.8, {}, nullptr, &people), palplab::InputError);
  fs::remove_all(d);
}

TEST(PeopleVerdicts, GroupDescriptivesAreThoseOfTheTestedValues) {
  // The tested session is the phase's last (session 2 here), unpooled; groups in study order;
  // a group without values has no mean, one with one value no SD; undefined values left out.
  Study study = exp2();
  study.analyses.resize(1);  // descriptives of palpation_force: no test, no cell
  Analysis a;
  a.kind = "pairwise_t";
  a.measure = "palpation_force";
  a.phase = "training";
  study.analyses.push_back(a);
  a.kind = "anova_oneway";  // the same cell again: listed once
  study.analyses.push_back(a);
  std::vector<SimValue> values = {
      {"p1", "A", "training", 1, "palpation_force", 9.0},  // not the last session
      {"p1", "A", "training", 2, "palpation_force", 2.0},
      {"p2", "A", "training", 2, "palpation_force", 4.0},
      {"p3", "A", "training", 2, "palpation_force", std::nullopt},
      {"p4", "B", "training", 2, "palpation_force", 5.0},
      {"p5", "B", "training", 2, "exploration_time", 1.0},  // another measure
  };
  const auto d = tested_group_descriptives(study, values);
  ASSERT_EQ(d.size(), 3u);
  EXPECT_EQ(d[0].cell, "palpation_force training");
  EXPECT_EQ(d[0].group, "A");
  EXPECT_EQ(d[0].n, 2);
  EXPECT_DOUBLE_EQ(d[0].mean, 3.0);
  EXPECT_DOUBLE_EQ(d[0].sd, std::sqrt(2.0));
  // t(0.975, 1) = 12.706: 3 ± 12.706 · 1
  EXPECT_NEAR(d[0].ci_low, 3.0 - 12.7062, 1e-3);
  EXPECT_EQ(d[1].group, "B");
  EXPECT_EQ(d[1].n, 1);
  EXPECT_DOUBLE_EQ(d[1].mean, 5.0);
  EXPECT_TRUE(std::isnan(d[1].sd));
  EXPECT_TRUE(std::isnan(d[1].ci_low));
  EXPECT_EQ(d[2].group, "C");
  EXPECT_EQ(d[2].n, 0);
  EXPECT_TRUE(std::isnan(d[2].mean));
  // No order while a group has no mean; with one, largest first, ties in study order.
  EXPECT_EQ(order_of_means(d, "palpation_force training"), "");
  values.push_back({"p6", "C", "training", 2, "palpation_force", 3.0});
  EXPECT_EQ(order_of_means(tested_group_descriptives(study, values), "palpation_force training"),
            "B > A = C");
}

TEST(PeopleVerdicts, TheSummaryGivesGroupMeansOrdersAndThePeoplesPattern) {
  // Four replicates of a two-group study with one test (people: significant, G1 > G2, people's
  // intervals G1 [2, 3], G2 [1, 2]); the fourth replicate is an older record without groups.
  const auto d = scratch("groups");
  const std::string file = (d / "replicates.jsonl").string();
  const double p[4] = {0.01, 0.01, 0.3, 0.01};
  const double m1[3] = {2.5, 2.5, 1.5}, m2[3] = {1.5, 2.5, 1.8};  // #1 ties, #2 order swapped
  {
    std::ofstream o(file);
    for (int r = 0; r < 4; ++r) {
      nlohmann::json rec = {
          {"n", 5},
          {"replicate", r},
          {"seed", r + 1},
          {"study", "s"},
          {"study_sha256", std::string(64, 'a')},
          {"tests", {{{"id", "T"}, {"p", p[r]}, {"effect", 1.0}, {"effect_name", "hedges_g"}}}}};
      if (r < 3)
        rec["groups"] = {
            {{"cell", "f t"}, {"group", "G1"}, {"n", 5}, {"mean", m1[r]}, {"sd", 0.1 * (r + 1)}},
            {{"cell", "f t"}, {"group", "G2"}, {"n", 5}, {"mean", m2[r]}, {"sd", 0.2}}};
      o << rec.dump() << "\n";
    }
  }
  const auto plain = power_summary({file}, 0.05, 0.8);
  ASSERT_TRUE(plain.contains("groups"));
  ASSERT_EQ(plain.at("groups").size(), 2u);
  const auto& g1 = plain.at("groups")[0].at("by_n")[0];
  EXPECT_EQ(g1.at("replicates").get<long>(), 3);  // the older record has none
  EXPECT_DOUBLE_EQ(g1.at("mean_median").get<double>(), 2.5);
  EXPECT_DOUBLE_EQ(g1.at("mean_q025").get<double>(), 1.5 + 0.05 * 1.0);  // type 7
  EXPECT_DOUBLE_EQ(g1.at("sd_median").get<double>(), 0.2);
  const auto& orders = plain.at("orders")[0].at("by_n")[0].at("orders");
  ASSERT_EQ(orders.size(), 3u);  // once each: a tie is no order
  std::set<std::string> seen;
  for (const auto& x : orders) {
    seen.insert(x.at("order").get<std::string>());
    EXPECT_EQ(x.at("count").get<long>(), 1);
  }
  EXPECT_EQ(seen, (std::set<std::string>{"G1 > G2", "G1 = G2", "G2 > G1"}));

  PeopleVerdicts people;
  people.file = "people.csv";
  people.tests = {{"T", 0.001, 1.5, "hedges_g"}};
  people.n = {{"G1", 5}, {"G2", 5}};
  people.resamples = 100;
  people.groups = {{"f t", "G1", 5, 2.5, 0.4, 2.0, 3.0}, {"f t", "G2", 5, 1.5, 0.4, 1.0, 2.0}};
  RightModel& right = people.right[5];
  right.agree = {{"T", 90}};
  right.all_agree = 90;
  right.median_agreeing = 1;
  right.same_order = {{"f t", 95}};
  right.inside = {{"f t\tG1", 85}, {"f t\tG2", 84}};
  right.all_orders = 95;
  right.all_inside = 80;
  right.pattern = 70;
  const auto s = power_summary({file}, 0.05, 0.8, {}, nullptr, &people);
  // Inside: G1 in #0, #1 (2.5); G2 in #0 (1.5), #2 (1.8), not #1 (2.5).
  EXPECT_EQ(s.at("groups")[0].at("by_n")[0].at("inside").get<long>(), 2);
  EXPECT_EQ(s.at("groups")[1].at("by_n")[0].at("inside").get<long>(), 2);
  EXPECT_DOUBLE_EQ(s.at("groups")[0].at("people").at("ci_high").get<double>(), 3.0);
  const auto& o = s.at("orders")[0];
  EXPECT_EQ(o.at("people").at("order"), "G1 > G2");
  EXPECT_TRUE(o.at("people").at("compared").get<bool>());
  EXPECT_DOUBLE_EQ(o.at("by_n")[0].at("right_model").get<double>(), 0.95);
  EXPECT_DOUBLE_EQ(s.at("groups")[1].at("by_n")[0].at("right_model").get<double>(), 0.84);
  EXPECT_EQ(o.at("by_n")[0].at("same").get<long>(), 1);  // #0 (#1 is a tie)
  const auto& b = s.at("people").at("by_n")[0];
  EXPECT_EQ(b.at("group_replicates").get<long>(), 3);
  EXPECT_EQ(b.at("all_orders").get<long>(), 1);
  EXPECT_EQ(b.at("all_inside").get<long>(), 1);  // #0
  EXPECT_EQ(b.at("pattern").get<long>(), 1);     // #0: significant, in order, inside
  EXPECT_DOUBLE_EQ(b.at("right_model").at("pattern").get<double>(), 0.7);
  // The report shows both.
  const std::string md = write_power_report(s, (d / "out").string());
  EXPECT_NE(md.find("## Group means"), std::string::npos);
  EXPECT_NE(md.find("| f t | G2 | 5 | 3 | 1.800 [1.515, 2.465] | 0.200 | 1.500 [1.000, 2.000] | "
                    "0.400 | 2/3 (right model 0.840) |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("The people's order: 1/3 (right model 0.950)"), std::string::npos) << md;
  EXPECT_NE(md.find("(people: G1 > G2)"), std::string::npos) << md;
  // Every verdict among the 3 with groups is not known apart (the 4th has none): "(above)".
  EXPECT_NE(md.find("| 5 | 3 | (above) | 1/3 ["), std::string::npos) << md;
  EXPECT_NE(md.find("Group means are in 3 of the 4 replicates"), std::string::npos) << md;
  // A people's tie is no order to reach: not compared, and not demanded by the pattern.
  PeopleVerdicts tie = people;
  tie.groups[1].mean = 2.5;
  const auto t = power_summary({file}, 0.05, 0.8, {}, nullptr, &tie);
  EXPECT_FALSE(t.at("orders")[0].at("people").at("compared").get<bool>());
  EXPECT_EQ(t.at("orders")[0].at("people").at("order"), "G1 = G2");
  EXPECT_TRUE(t.at("orders")[0].at("by_n")[0].at("same").is_null());
  EXPECT_EQ(t.at("people").at("by_n")[0].at("all_orders").get<long>(), 3);
  // A people's group the replicates do not have: another version of the study.
  PeopleVerdicts other = people;
  other.groups[1].group = "G3";
  EXPECT_THROW(power_summary({file}, 0.05, 0.8, {}, nullptr, &other), palplab::InputError);
  fs::remove_all(d);
}

TEST(PeopleVerdicts, MedianOfCounts) {
  EXPECT_DOUBLE_EQ(median_of_counts({0, 0, 3}), 2.0);
  EXPECT_DOUBLE_EQ(median_of_counts({1, 1}), 0.5);
  EXPECT_DOUBLE_EQ(median_of_counts({2, 0, 1}), 0.0);
  EXPECT_DOUBLE_EQ(median_of_counts({1, 0, 0, 1}), 1.5);
  EXPECT_TRUE(std::isnan(median_of_counts({0, 0})));
  EXPECT_FALSE(significant(NAN, 0.05));
  EXPECT_FALSE(significant(0.05, 0.05));
  EXPECT_TRUE(significant(0.0499, 0.05));
}
