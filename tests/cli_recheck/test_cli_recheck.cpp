// `palplab recheck` end to end on statistics with planted errors
// (tests/data/recheck/planted.json on tests/data/r/unequal.csv; the true values come from
// `palplab stats`, which test_vs_r checks against R): each verdict, the recomputed values, the
// exit code (1 when anything is inconsistent) and input errors (exit 2).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "../cli_support.hpp"

namespace {
using Result = palplab::testing::CliResult;
using palplab::testing::run_palplab;
using palplab::testing::write_temp;

std::string src(const std::string& rel) {
  return std::string(PALPLAB_SOURCE_DIR) + "/" + rel;
}

}  // namespace

TEST(CliRecheck, PlantedErrorsAreFound) {
  Result r = run_palplab("recheck " + src("tests/data/recheck/planted.json") + " --csv " +
                         src("tests/data/r/unequal.csv") + " --json");
  EXPECT_EQ(r.code, 1) << r.err;  // something is inconsistent
  auto j = nlohmann::json::parse(r.out);
  const auto& s = j["statistics"];
  ASSERT_EQ(s.size(), 8u);
  const char* expect[] = {"consistent", "rounding",     "inconsistent", "consistent",
                          "consistent", "inconsistent", "consistent",   "inconsistent"};
  for (size_t i = 0; i < 8; ++i) EXPECT_EQ(s[i]["verdict"], expect[i]) << s[i].dump();
  EXPECT_EQ(j["inconsistent"], 3);
  // The truncated F: only the statistic is off, by one unit in the last digit.
  for (const auto& p : s[1]["parts"])
    EXPECT_EQ(p["verdict"], p["part"] == "statistic" ? "rounding" : "consistent") << p.dump();
  // The pooled df: df2 and p are flagged, with the recomputed values.
  for (const auto& p : s[2]["parts"]) {
    if (p["part"] == "df2") {
      EXPECT_EQ(p["verdict"], "inconsistent");
      EXPECT_EQ(p["recomputed"], 13);
    }
    if (p["part"] == "p") {
      EXPECT_EQ(p["verdict"], "inconsistent");  // .0016 is not < .001
    }
  }
  EXPECT_NEAR(s[0]["parts"][2]["recomputed"].get<double>(), 11.045142662145704, 1e-9);
  EXPECT_EQ(s[0]["recomputed"], "F(2, 13) = 11.05, p = .002");
  // "p < .05" for p = .051 claims a significance that is not there.
  EXPECT_EQ(s[5]["parts"][2]["verdict"], "inconsistent");
  // Text output names the inconsistent part.
  r = run_palplab("recheck " + src("tests/data/recheck/planted.json") + " --csv " +
                  src("tests/data/r/unequal.csv"));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("A-C-transposed: \"t(3.02) = -3.20, p = .049\" -> inconsistent"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("8 statistics, 3 inconsistent"), std::string::npos);
}

TEST(CliRecheck, AllConsistentExitsZero) {
  std::string f = write_temp("ok.json", R"({"value": "force", "group": "group", "statistics": [
      {"text": "F(2, 13) = 11.05, p = .002", "where": ["phase=post"]},
      {"text": "t(3.59) = -2.88, p = .051", "pair": ["B", "C"], "where": ["phase=post"]}]})");
  Result r = run_palplab("recheck " + f + " --csv " + src("tests/data/r/unequal.csv"));
  EXPECT_EQ(r.code, 0) << r.out << r.err;
  std::filesystem::remove(f);
}

TEST(CliRecheck, BadInputIsExitTwo) {
  const std::string csv = " --csv " + src("tests/data/r/unequal.csv");
  for (
      const char* bad :
      {R"({"statistics": [{"text": "F = 11.05", "value": "force", "group": "group"}]})",
       R"({"statistics": [{"text": "t(3) = 1.2, p = .3", "value": "force", "group": "group"}]})",
       R"({"statistics": [{"text": "F(2, 13) = 1.2, p = .3", "value": "force", "group": "group", "typo": 1}]})",
       R"({"statistics": [{"text": "F(2, 13) = 1.2, p = .3", "value": "nosuch", "group": "group"}]})",
       R"({"statistics": [{"text": "F(2, 13) = 1.2, p = .3", "test": "chi2", "value": "force", "group": "group"}]})",
       R"({"stats": []})", "not json"}) {
    std::string f = write_temp("bad.json", bad);
    Result r = run_palplab("recheck " + f + csv);
    EXPECT_EQ(r.code, 2) << bad << "\n" << r.out << r.err;
    EXPECT_FALSE(r.err.empty()) << bad;
    std::filesystem::remove(f);
  }
}

// Review findings: a duplicate key was not detected (the last one won); impossible printed
// values were graded "inconsistent" (exit 1) instead of being malformed input; "pair" on an F
// test was ignored; an empty "statistics" exited 0; the top-level path was ".value".
TEST(CliRecheck, MalformedReportsAreExitTwoWithTheLocation) {
  const std::string csv = " --csv " + src("tests/data/r/unequal.csv");
  struct Case {
    const char *json, *where, *what;
  };
  const std::vector<Case> cases = {
      {R"({"value":"force","value":"x","group":"group","statistics":[{"text":"F(2, 13) = 1.2, p = .3"}]})",
       ":1:18: $.value:", "duplicate key (first defined at line 1, column 10)"},
      {R"({"value":"force","group":"group","statistics":[{"text":"F(2, 6) = -7.14, p = .026"}]})",
       ":1:56: $.statistics[0].text:", "an F statistic is never negative"},
      {R"({"value":"force","group":"group","statistics":[{"text":"F(2, 6) = 7.14, p = 1.5"}]})",
       ":1:56: $.statistics[0].text:", "a p-value is at most 1"},
      {R"({"value":"force","group":"group","statistics":[{"text":"F(2, 6) = 7.14, p > 1"}]})",
       ":1:56: $.statistics[0].text:", "no p-value is above 1"},
      {R"({"value":"force","group":"group","statistics":[{"text":"F(2, 6) = 7.14, p < 0"}]})",
       ":1:56: $.statistics[0].text:", "no p-value is below 0"},
      {R"({"value":"force","group":"group","statistics":[{"text":"F(0, 0) = 7.14, p = .026"}]})",
       ":1:56: $.statistics[0].text:", "degrees of freedom must be > 0"},
      {R"({"value":"force","group":"group","statistics":[{"text":"t(0) = 1.2, p = .3","pair":["A","B"]}]})",
       ":1:56: $.statistics[0].text:", "degrees of freedom must be > 0"},
      {R"({"value":"force","group":"group","statistics":[{"text":"F(2, 6) = 7.14, p = .026","pair":["A","B"]}]})",
       ":1:83: $.statistics[0].pair:", "applies to t-tests only"},
      {R"({"value":"force","group":"group","statistics":[]})",
       ":1:47: $.statistics:", "nothing to check"},
      {R"({"value":5,"group":"group","statistics":[{"text":"F(2, 6) = 7.14, p = .026"}]})",
       ":1:10: $.value:", "expected a string"},
      {R"({"value":"force","group":"group","statistics":[{"id":"x","text":"F(2, 6) = 7.14, p = .026"},{"id":"x","text":"F(2, 6) = 7.14, p = .026"}]})",
       ":1:99: $.statistics[1].id:", "duplicate id \"x\""},
      {R"({"value":"force","group":"group","statistics":[{"text":"F(2, 6) = 7.14, p = .026","where":["phase"]}]})",
       ":1:92: $.statistics[0].where[0]:", "expected a \"COL=VALUE\" string"},
  };
  for (const auto& c : cases) {
    const std::string f = write_temp("malformed.json", c.json);
    const Result r = run_palplab("recheck " + f + csv);
    EXPECT_EQ(r.code, 2) << c.json << "\n" << r.out << r.err;
    EXPECT_NE(r.err.find("error: " + f + c.where), std::string::npos)
        << c.json << "\nexpected '" << f + c.where << "' in: " << r.err;
    EXPECT_NE(r.err.find(c.what), std::string::npos) << c.what << " in: " << r.err;
    std::filesystem::remove(f);
  }
}
