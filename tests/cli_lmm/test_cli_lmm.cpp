// `palplab lmm` end to end: the JSON contract (docs/FORMATS.md), --where, --ml, the text tables,
// and exit 2 with a located message for bad input. Numerical agreement with lme4/lmerTest is
// tested in tests/analysis/test_lmm.cpp.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "../cli_support.hpp"

namespace {
using Result = palplab::testing::CliResult;
using palplab::testing::run_palplab;
using palplab::testing::write_temp;

std::string fixture(const std::string& name) {
  return std::string(PALPLAB_SOURCE_DIR) + "/tests/data/lmm/" + name;
}

const std::string kStudy = "--formula \"value ~ group * session + (1 | participant)\"";

}  // namespace

TEST(CliLmm, JsonContract) {
  Result r = run_palplab("lmm --csv " + fixture("study.csv") + " " + kStudy + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["method"], "REML");
  EXPECT_EQ(j["n_obs"], 114);  // 115 rows, one NA value dropped
  EXPECT_EQ(j["rows_dropped_na"], 1);
  EXPECT_EQ(j["n_groups"], 23);
  EXPECT_EQ(j["df"], 8);
  for (const char* k : {"reml_criterion", "loglik", "aic", "bic", "sigma"})
    EXPECT_TRUE(j[k].is_number()) << k;
  EXPECT_NEAR(j["reml_criterion"].get<double>(), 212.98425454266803, 1e-8);
  EXPECT_EQ(j["random_effects"]["group"], "participant");
  EXPECT_NEAR(j["random_effects"]["sd_intercept"].get<double>(), 0.95469556839512704, 1e-6);
  const char* names[] = {"(Intercept)", "groupB",         "groupC",
                         "session",     "groupB:session", "groupC:session"};
  ASSERT_EQ(j["fixed_effects"].size(), 6u);
  for (int i = 0; i < 6; ++i) {
    const auto& fe = j["fixed_effects"][i];
    EXPECT_EQ(fe["term"], names[i]);
    for (const char* k : {"estimate", "se", "df", "t", "p"}) EXPECT_TRUE(fe[k].is_number()) << k;
  }
  ASSERT_EQ(j["anova"].size(), 3u);
  EXPECT_EQ(j["anova"][2]["term"], "group:session");
  EXPECT_EQ(j["anova"][2]["num_df"], 2);
  EXPECT_NEAR(j["anova"][2]["f"].get<double>(), 5.1393722244601863, 1e-5);
  // Partial η² = F·q / (F·q + den_df) and its noncentral-F interval, which contains it.
  for (const auto& a : j["anova"]) {
    const double f = a["f"].get<double>(), q = a["num_df"].get<double>(),
                 den = a["den_df"].get<double>(), pes = a["partial_eta_squared"].get<double>();
    EXPECT_NEAR(pes, f * q / (f * q + den), 1e-12) << a["term"];
    ASSERT_TRUE(a.contains("partial_eta_squared_ci")) << a["term"];
    const double lo = a["partial_eta_squared_ci"][0].get<double>(),
                 hi = a["partial_eta_squared_ci"][1].get<double>();
    EXPECT_GE(lo, 0);
    EXPECT_LT(lo, hi);
    EXPECT_LT(hi, 1);
    // A two-sided 95 % interval's lower bound leaves 0 exactly when the F test's p < .025.
    EXPECT_EQ(lo > 0, a["p"].get<double>() < 0.025) << a["term"];
  }
  EXPECT_EQ(j["vcov"].size(), 6u);
}

TEST(CliLmm, MlReportsDevianceAndLogLik) {
  Result r = run_palplab("lmm --csv " + fixture("sleepstudy.csv") +
                         " --formula \"Reaction ~ Days + (Days | Subject)\" --ml --json");
  ASSERT_EQ(r.code, 0) << r.err;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["method"], "ML");
  EXPECT_FALSE(j.contains("reml_criterion"));
  EXPECT_NEAR(j["deviance"].get<double>(), -2 * j["loglik"].get<double>(), 1e-9);
  EXPECT_EQ(j["random_effects"]["slope"], "Days");
  EXPECT_TRUE(j["random_effects"]["correlation"].is_number());
}

// --where keeps the same rows as a CSV that contains only those rows.
TEST(CliLmm, WhereEqualsPreFilteredFile) {
  std::ifstream in(fixture("study.csv"));
  std::string line, kept;
  std::getline(in, line);
  kept = line + "\n";
  while (std::getline(in, line))
    if (line.find(",C,") == std::string::npos) kept += line + "\n";
  std::string ab = write_temp("ab.csv", kept);
  Result a = run_palplab("lmm --csv " + fixture("study.csv") + " " + kStudy +
                         " --where group=A --where group=B --json");
  Result b = run_palplab("lmm --csv " + ab + " " + kStudy + " --json");
  ASSERT_EQ(a.code, 0) << a.err;
  ASSERT_EQ(b.code, 0) << b.err;
  auto ja = nlohmann::json::parse(a.out), jb = nlohmann::json::parse(b.out);
  EXPECT_EQ(ja["n_obs"], jb["n_obs"]);
  ASSERT_EQ(ja["fixed_effects"].size(), 4u);
  EXPECT_EQ(ja["fixed_effects"][1]["term"], "groupB");
  for (int i = 0; i < 4; ++i)
    EXPECT_DOUBLE_EQ(ja["fixed_effects"][i]["estimate"].get<double>(),
                     jb["fixed_effects"][i]["estimate"].get<double>());
}

TEST(CliLmm, TextTables) {
  Result r = run_palplab("lmm --csv " + fixture("study.csv") + " " + kStudy);
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* s : {"REML criterion at convergence: 212.98", "Random effects:", "participant",
                        "Residual", "Fixed effects:", "groupC:session",
                        "Type III Analysis of Variance Table with Satterthwaite's method",
                        "Number of obs: 114, groups:  participant, 23"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s << "\n" << r.out;
}

TEST(CliLmm, BadInputExitsTwoWithLocation) {
  Result r = run_palplab("lmm --csv " + fixture("study.csv") +
                         " --formula \"value ~ group + (1 | participant) + (1 | group)\"");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--formula"), std::string::npos) << r.err;
  r = run_palplab("lmm --csv " + fixture("study.csv") +
                  " --formula \"value ~ grp + (1 | participant)\"");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("grp"), std::string::npos) << r.err;
  std::string bad = write_temp("bad.csv", "y,g,x\n1,a,1\n2,a,2\nabc,b,1\n3,b,2\n");
  r = run_palplab("lmm --csv " + bad + " --formula \"y ~ x + (1 | g)\"");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find(":4:"), std::string::npos) << r.err;  // CSV line of 'abc'
  r = run_palplab("lmm --csv " + bad + " --formula \"x ~ y + (1 + g | g)\"");
  EXPECT_EQ(r.code, 2);
  r = run_palplab("lmm --csv /nonexistent.csv " + kStudy);
  EXPECT_EQ(r.code, 2);
  r = run_palplab("lmm --csv " + fixture("study.csv") + " " + kStudy + " --where nosuch=1");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("nosuch"), std::string::npos) << r.err;
  // A constant response (a learning curve of a measure nobody ever scored) was a crash.
  std::string flat = "value,group,session,participant\n";
  for (int g = 0; g < 2; ++g)
    for (int p = 0; p < 3; ++p)
      for (int s = 0; s < 3; ++s)
        flat += "0,G" + std::to_string(g) + "," + std::to_string(s) + ",p" + std::to_string(g) +
                std::to_string(p) + "\n";
  const std::string flat_csv = write_temp("flat.csv", flat);
  r = run_palplab("lmm --csv " + flat_csv +
                  " --formula \"value ~ group * session + (1 + session | participant)\"");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("fitted exactly by the fixed effects"), std::string::npos) << r.err;
}

// Review findings: a fixed effect that is also the grouping factor printed df 0.000, p 1.3e-08
// and partial eta^2 1.000 [0, 0] with exit 0; the grouping factor as the slope or the response
// crashed (segmentation fault); a directory was "empty CSV file".
TEST(CliLmm, UnidentifiableModelsExitTwo) {
  const std::string csv = " --csv " + fixture("study.csv");
  Result r = run_palplab("lmm" + csv + " --formula \"value ~ group + (1 | group)\"");
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("fixed-effect term 'group' is also the random-effects grouping factor"),
            std::string::npos)
      << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
  r = run_palplab("lmm" + csv + " --formula \"value ~ group + (session | session)\"");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("random slope 'session' is also the grouping factor"), std::string::npos)
      << r.err;
  r = run_palplab("lmm" + csv + " --formula \"session ~ group + (1 | session)\"");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("is also the grouping factor"), std::string::npos) << r.err;
  const std::string dir = palplab::testing::process_scratch().string();
  r = run_palplab("lmm --csv " + dir + " " + kStudy);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("is a directory, expected a CSV file"), std::string::npos) << r.err;
}

// Review finding: a covariate in units that make it 1e15 (session x 1e15) was "rank deficient
// (...) some factor combinations are empty or columns are collinear" although the design has
// full rank; the fit now equals the one on session, the estimates in the column's units.
// (Numerical agreement: tests/analysis/test_lmm.cpp, LmmFit.BadlyScaledCovariate...)
TEST(CliLmm, BadlyScaledCovariateFits) {
  std::string text = palplab::testing::slurp(fixture("study.csv"));
  std::istringstream in(text);
  std::string line, out;
  std::getline(in, line);
  out += line + ",session_fs\n";
  while (std::getline(in, line)) {
    const size_t a = line.find(','), b = line.find(',', a + 1), c = line.find(',', b + 1);
    out += line + "," + line.substr(b + 1, c - b - 1) + "e15\n";
  }
  const std::string csv = write_temp("scaled_session.csv", out);
  Result plain = run_palplab("lmm --csv " + csv + " " + kStudy + " --json");
  Result scaled = run_palplab(
      "lmm --csv " + csv + " --formula \"value ~ group * session_fs + (1 | participant)\" --json");
  ASSERT_EQ(plain.code, 0) << plain.err;
  ASSERT_EQ(scaled.code, 0) << scaled.err;
  const auto a = nlohmann::json::parse(plain.out)["fixed_effects"];
  const auto b = nlohmann::json::parse(scaled.out)["fixed_effects"];
  ASSERT_EQ(a.size(), 6u);
  ASSERT_EQ(b.size(), 6u);
  EXPECT_EQ(b[3]["term"], "session_fs");
  for (int i = 0; i < 6; ++i) {
    const double k = i >= 3 ? 1e15 : 1;
    const double want = a[i]["estimate"].get<double>();
    EXPECT_NEAR(b[i]["estimate"].get<double>() * k, want, 1e-7 * std::abs(want)) << i;
    EXPECT_NEAR(b[i]["t"].get<double>(), a[i]["t"].get<double>(),
                1e-7 * std::abs(a[i]["t"].get<double>()))
        << i;
  }
  // Truly collinear columns stay an error, at any scale.
  Result r = run_palplab("lmm --csv " + csv +
                         " --formula \"value ~ session + session_fs + (1 | participant)\"");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.err.find("rank deficient"), std::string::npos) << r.err;
}

// Factor levels and column names reach the text tables: control characters are escaped there,
// and a long bad response value is cut in the error.
TEST(CliLmm, NamesEscapedAndLongFieldsCut) {
  std::string csv = "y,g,grp\n";
  const double y[] = {1.1, 2.3, 1.9, 3.2, 2.8, 3.9, 2.2, 3.1, 4.4, 3.0, 3.8, 5.1};
  for (int i = 0; i < 12; ++i)
    csv += std::to_string(y[i]) + ",p" + std::to_string(i % 4) + "," + (i % 2 ? "B\x1b[31m" : "A") +
           "\n";
  Result r = run_palplab("lmm --csv " + write_temp("esc_lmm.csv", csv) +
                         " --formula \"y ~ grp + (1 | g)\"");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out.find('\x1b'), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("grpB\\x1b[31m "), std::string::npos) << r.out;
  const std::string bad = write_temp(
      "long_lmm.csv", "y,g,x\n1,a,1\n2,a,2\n" + std::string(1'000'000, 'z') + ",b,1\n3,b,2\n");
  r = run_palplab("lmm --csv " + bad + " --formula \"y ~ x + (1 | g)\"");
  EXPECT_EQ(r.code, 2);
  EXPECT_LT(r.err.size(), 400u) << r.err.substr(0, 400);
  EXPECT_NE(r.err.find("\u2026 (1000000 bytes)'"), std::string::npos) << r.err.substr(0, 400);
}

// A REML minimum on the boundary (participant variance 0: the profile is lowest at theta = 0)
// was reported as theta 1.2e-8, an SD of 3.5e-7 and no warning (review 2026-12-07): lme4's
// isSingular() takes a diagonal element of the relative factor below 1e-4 as singular. The fit
// is put on the bound, as lme4's bounded optimiser puts it, and says so.
TEST(CliLmm, ABoundaryOptimumIsASingularFit) {
  const std::string csv = write_temp("singular.csv",
                                     "participant,group,session,value\nP01,B,1,44\nP01,B,2,40\n"
                                     "P01,B,1,53.333333333333336\nP02,A,2,100\nP02,A,1,0\n"
                                     "P03,A,2,100\nP03,A,1,14.285714285714286\n"
                                     "P04,B,1,4.3478260869565215\nP04,B,2,17.24137931034483\n"
                                     "P04,B,1,100\n");
  const Result r = run_palplab("lmm --csv " + csv +
                               " --formula \"value ~ group * session + (1 | participant)\" --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["random_effects"]["sd_intercept"].get<double>(), 0.0) << r.out;
  ASSERT_EQ(j["warnings"].size(), 1u) << r.out;
  EXPECT_NE(j["warnings"][0].get<std::string>().find("singular fit"), std::string::npos);
  // On the bound the model is ordinary least squares: REML sigma² = RSS / (n - p).
  EXPECT_NEAR(j["sigma"].get<double>(), 28.8431, 1e-4);
  EXPECT_NEAR(j["reml_criterion"].get<double>(), 60.835445, 1e-6);
}

// lmm fitted a tidy table's measures (%, s, N) pooled into one response with exit 0, where
// `stats` refuses (review 2026-12-07); a --where that keeps no row names the filter and what
// its column holds (it said "no complete data rows match the --where filters").
TEST(CliLmm, PooledMeasuresAndFiltersKeepingNoRowAreSaid) {
  const std::string csv =
      write_temp("lmm_tidy.csv",
                 "participant,group,session,measure,value\nP1,A,1,force,2.5\nP1,A,2,force,2.4\n"
                 "P2,A,1,force,2.7\nP2,A,2,force,2.9\nP3,B,1,force,2.9\nP3,B,2,force,3.0\n"
                 "P4,B,1,force,3.1\nP4,B,2,force,3.3\nP1,A,1,time,30\nP1,A,2,time,31\n");
  const std::string formula = " --formula \"value ~ group + session + (1 | participant)\"";
  Result r = run_palplab("lmm --csv " + csv + formula);
  palplab::testing::expect_exit2(
      r, {csv + ":10: the rows analysed mix measures: 'force' (line 2) and 'time' (column "
                "'measure'); analyse one at a time with --where measure=force"});
  r = run_palplab("lmm --csv " + csv + formula + " --where measure=Force");
  palplab::testing::expect_exit2(
      r, {"no row of " + csv + " matches --where measure=Force (10 data rows;",
          "column 'measure' holds 'force', 'time'"});
  r = run_palplab("lmm --csv " + csv + formula + " --where measure=force");
  EXPECT_EQ(r.code, 0) << r.err;
}

// One 'x' among session numbers made `session` a factor of every value seen (a 5-df session
// term) without a word (review 2026-12-07): documented, and now also said.
TEST(CliLmm, ANumericColumnTakenAsAFactorIsSaid) {
  std::string csv = "participant,group,session,value\n";
  const double v[] = {2.1, 2.5, 2.2, 2.9, 2.4, 2.6, 3.1, 2.8};
  int k = 0;
  for (const char* p : {"P1", "P2", "P3", "P4"})
    for (int s = 1; s <= 2; ++s)
      csv += std::string(p) + "," + (p[1] < '3' ? "A" : "B") + "," +
             (k == 5 ? std::string("x") : std::to_string(s)) + "," + std::to_string(v[k]) + "\n",
          ++k;
  const std::string file = write_temp("lmm_typo.csv", csv);
  const Result r = run_palplab("lmm --csv " + file +
                               " --formula \"value ~ group + session + (1 | participant)\" --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  bool said = false;
  for (const auto& w : j["warnings"])
    said = said || w.get<std::string>() ==
                       "column 'session' is taken as a factor: 'x' at line 7 is no number, "
                       "though 7 of its 8 values used are (a typo, or a missing value not "
                       "written NA?)";
  EXPECT_TRUE(said) << r.out;
}
