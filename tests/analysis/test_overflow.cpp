// Statistics beyond the range of a double and input text shown in messages and tables: t and F
// whose squares (or F itself) overflow get their p from the logarithmic tail (checked against
// closed forms), one-sided TOST tails never go below the 1e-300 floor, large statistics print in
// scientific notation (never cut), and labels / bad fields are escaped and cut.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <regex>
#include <string>

#include "analysis/csv.hpp"
#include "analysis/grouped.hpp"
#include "analysis/posthoc.hpp"
#include "analysis/summary.hpp"
#include "analysis/two_sample.hpp"
#include "common/input_error.hpp"
#include "tests/analysis/support.hpp"

using namespace palplab::analysis;
using palplab::InputError;

namespace {

StatsSummary summarize_csv(const std::string& csv, StatsOptions opt = {}) {
  return summarize(group_table(parse_csv(csv, "t.csv"), "v", "g", {}), opt);
}

// A = 1e-100, 2e-100, 3e-100 (SD 1e-100), B = 1e100 three times (constant): within the
// documented 1e150 limit, t = -1e100 / sqrt(1e-200 / 3) = -sqrt(3)·1e200 and F = MS_between /
// MS_within = 1.5e200 / 5e-201 = 3e400.
const char* kHuge = "g,v\nA,1e-100\nA,2e-100\nA,3e-100\nB,1e100\nB,1e100\nB,1e100\n";
}  // namespace

TEST(WideTails, TBeyondTheSquareOfADoubleMatchesClosedForms) {
  // df = 1 (Cauchy): P(|T| > t) = (2/π) atan(1/t).
  for (double t : {1e100, 1e149, 1e151, 1e160, 1e200, 1e299}) {
    const double want = 2 / std::numbers::pi * std::atan(1 / t);
    expect_rel(t_two_sided_p_wide(t, 1), want, 1e-13, "df 1");
    expect_rel(t_two_sided_p_wide(-t, 1), want, 1e-13, "df 1, negative t");
    expect_rel(t_upper_p(t, 1), want / 2, 1e-13, "one-sided");
  }
  EXPECT_EQ(t_two_sided_p_wide(1e301, 1), kPFloor);  // 6.4e-302: below the floor
  // Across the switch at 1e150 the tail follows its power law t^-df (exact to O(1/t²)).
  for (double df : {1.2, 1.5, 1.9}) {
    const double below = t_two_sided_p_wide(1e149, df), above = t_two_sided_p_wide(1e151, df);
    expect_rel(above / below, std::pow(100.0, -df), 1e-11, "power law across the switch");
    expect_rel(t_two_sided_p_wide(1e150 * (1 + 1e-9), df) / t_two_sided_p(1e150, df),
               std::pow(1 + 1e-9, -df), 1e-11, "continuity at the switch");
  }
  // df >= 2: t^-2 < 1e-300 already; an infinite t (an SE of subnormal size) is the bound too.
  for (double df : {2.0, 5.0, 1e4, 1e12}) EXPECT_EQ(t_two_sided_p_wide(1e200, df), kPFloor);
  EXPECT_EQ(t_two_sided_p_wide(-INFINITY, 1), kPFloor);
  EXPECT_TRUE(std::isnan(t_two_sided_p_wide(NAN, 3)));
  EXPECT_TRUE(std::isnan(t_two_sided_p_wide(2, 0)));
  // Below the floor a one-sided tail is the bound, not half of it (was 5e-301).
  EXPECT_EQ(t_upper_p(1e4, 1000), kPFloor);
  EXPECT_EQ(t_upper_p(-1e200, 3), 1.0);
  expect_rel(t_upper_p(2.5, 7), t_two_sided_p(2.5, 7) / 2, 1e-15);
  expect_rel(t_upper_p(-2.5, 7), 1 - t_two_sided_p(2.5, 7) / 2, 1e-15);
}

TEST(WideTails, FBeyondADoubleMatchesClosedForms) {
  // F(2, 1): P(F > f) = (1 + 2f)^(-1/2); F(2, 2): 1 / (1 + f).
  for (double log10_f : {250.0, 299.0, 301.0, 400.0, 599.0}) {
    const double log_f = log10_f * std::log(10.0);
    expect_rel(f_upper_p_log(log_f, 2, 1), std::pow(10.0, -0.5 * log10_f) / std::sqrt(2.0), 1e-12,
               "F(2, 1) at 1e" + std::to_string(log10_f));
  }
  EXPECT_EQ(f_upper_p_log(601 * std::log(10.0), 2, 1), kPFloor);  // 2.2e-301
  expect_rel(f_upper_p_log(250 * std::log(10.0), 2, 2), 1e-250, 1e-12, "F(2, 2)");
  EXPECT_EQ(f_upper_p_log(400 * std::log(10.0), 2, 2), kPFloor);
  // F(1, ν) = T²: the same tail as t.
  expect_rel(f_upper_p_log(2 * std::log(1e200), 1, 1.5), t_two_sided_p_wide(1e200, 1.5), 1e-13);
  // Ordinary F values go through f_upper_p unchanged.
  EXPECT_EQ(f_upper_p_log(std::log(4.0), 2, 10), f_upper_p(4.0, 2, 10));
  EXPECT_EQ(f_upper_p_log(INFINITY, 3, 4), kPFloor);
}

TEST(Overflow, HugeTAndFHaveBoundPValuesAndReadableText) {
  const StatsSummary s = summarize_csv(kHuge);
  // ANOVA: F = 3e400 is beyond a double; p from log F (P ~ F^-2 < 1e-300: the bound).
  EXPECT_TRUE(s.anova.defined);
  expect_rel(s.anova_log10_F, std::log10(3.0) + 400, 1e-14, "log10 F");
  EXPECT_EQ(s.anova.p, kPFloor);
  const auto j = to_json(s);
  EXPECT_TRUE(j["anova"]["F"].is_null());
  EXPECT_EQ(j["anova"]["p"], kPFloor);
  EXPECT_EQ(j["anova"]["p_is_bound"], true);
  EXPECT_EQ(j["anova"]["apa"], "F(1, 4) = 3.00e+400, p < .001");
  // t = -sqrt(3)e200, df 2: P ~ 2/t² < 1e-300.
  const auto& pw = j["pairwise"][0];
  expect_rel(pw["t"].get<double>(), -std::sqrt(3.0) * 1e200, 1e-14, "t");
  EXPECT_EQ(pw["p"], kPFloor);
  EXPECT_EQ(pw["p_is_bound"], true);
  EXPECT_EQ(pw["apa"], "t(2) = -1.73e+200, p < .001");
  // The text never prints a number's digits cut off (it printed 62 of the 201 digits of t).
  const std::string text = to_text(s);
  EXPECT_FALSE(std::regex_search(text, std::regex("[0-9]{12}"))) << text;
  EXPECT_NE(text.find("t(2) = -1.73e+200, p < .001"), std::string::npos) << text;
  EXPECT_NE(text.find("F(1, 4) = 3.00e+400, p < .001"), std::string::npos) << text;
  EXPECT_NE(text.find("-1.732e+200"), std::string::npos) << text;
  EXPECT_EQ(text.find("n/a, n/a"), text.find("[n/a, n/a]") + 1) << text;  // only the g CI
}

TEST(Overflow, WelchDfOneKeepsTheTrueTinyP) {
  // A = 1e-100, 2e-100; B constant at 1e100: Welch df = 1, t = -1e100 / 5e-101 = -2e200, and
  // the Cauchy tail (2/π) atan(1/|t|) = 3.18e-201 is above the floor: a value, not the bound.
  const auto j = to_json(summarize_csv("g,v\nA,1e-100\nA,2e-100\nB,1e100\nB,1e100\n"));
  const auto& pw = j["pairwise"][0];
  EXPECT_DOUBLE_EQ(pw["df"].get<double>(), 1.0);
  expect_rel(pw["t"].get<double>(), -2e200, 1e-14, "t");
  expect_rel(pw["p"].get<double>(), 2 / std::numbers::pi * std::atan(1 / 2e200), 1e-13, "p");
  EXPECT_EQ(pw["p_is_bound"], false);
}

TEST(Overflow, InfiniteTFromASubnormalSeIsABound) {
  // A = 1e-320, 2e-320 (subnormal): SE ~ 5e-321 and t = -1e100 / SE overflows to -inf.
  const auto j = to_json(summarize_csv("g,v\nA,1e-320\nA,2e-320\nB,1e100\nB,1e100\n"));
  const auto& pw = j["pairwise"][0];
  EXPECT_TRUE(pw["t"].is_null());
  EXPECT_EQ(pw["p"], kPFloor);
  EXPECT_EQ(pw["apa"], "t(1) < -1.8e+308, p < .001");
  EXPECT_EQ(j["anova"]["p"], kPFloor);
}

TEST(Overflow, LeveneFBeyondADouble) {
  // Absolute deviations: A 1e-100, 0, 1e-100; B 1e100, 1e100. F = 5.4e400.
  const StatsSummary s = summarize_csv("g,v\nA,1e-100\nA,2e-100\nA,3e-100\nB,-1e100\nB,1e100\n");
  for (const auto& [a, l10] : {std::pair{s.levene, s.levene_log10_F},
                               std::pair{s.brown_forsythe, s.brown_forsythe_log10_F}}) {
    // SS_between = 1e200·(3·2/5)... : MS_between = 6e199·2 = 1.2e200, MS_within = (2/3)e-200/3.
    expect_rel(l10, std::log10(1.2e200 / (2.0 / 9 * 1e-200)), 1e-12, "log10 F");
    EXPECT_EQ(a.p, kPFloor);
  }
  const auto j = to_json(s);
  EXPECT_TRUE(j["levene"]["F"].is_null());
  EXPECT_EQ(j["levene"]["p"], kPFloor);
  EXPECT_NE(to_text(s).find("Levene (mean):           F(1, 3) = 5.40e+400, p < .001"),
            std::string::npos)
      << to_text(s);
}

TEST(Overflow, TostWithHugeMarginsIsEquivalentAtTheFloor) {
  // 90 % CI of the difference [-3.92, -1.58]: inside any margin of ±10 or more.
  const std::string csv = "g,v\nA,1\nA,2\nA,3\nA,2.5\nB,4\nB,5\nB,6\nB,4.5\n";
  for (double m : {1e100, 1e150, 1e160, 1e300, 1.7e308}) {
    StatsOptions opt;
    opt.margins = std::make_pair(-m, m);
    const auto s = summarize_csv(csv, opt);
    const auto& q = s.equivalence.at(0);
    EXPECT_EQ(q.p_low, kPFloor) << m;
    EXPECT_EQ(q.p_high, kPFloor) << m;
    EXPECT_EQ(q.p, kPFloor) << m;
    EXPECT_EQ(q.verdict, "equivalent") << m;
    EXPECT_EQ(to_json(s)["pairwise"][0]["equivalence"]["p_is_bound"], true) << m;
  }
  StatsOptions opt;
  opt.margins = std::make_pair(-10.0, 10.0);
  const auto q = summarize_csv(csv, opt).equivalence.at(0);
  EXPECT_GT(q.p, kPFloor);
  EXPECT_LT(q.p, 1e-4);
}

TEST(Apa, LargeStatisticsInScientificNotation) {
  EXPECT_EQ(apa_t(-1.7320508075688772e200, 2, 1e-300), "t(2) = -1.73e+200, p < .001");
  EXPECT_EQ(apa_t(999999.994, 2, 1e-300), "t(2) = 999999.99, p < .001");
  EXPECT_EQ(apa_t(1234567.0, 2, 1e-300), "t(2) = 1.23e+06, p < .001");
  EXPECT_EQ(apa_f(2.5e7, 1, 3, 1e-9), "F(1, 3) = 2.50e+07, p < .001");
  EXPECT_EQ(apa_f(NAN, 1, 3, NAN), "F(1, 3) = n/a, p = n/a");
}

TEST(ShownText, EscapedAndCutWithTheLength) {
  EXPECT_EQ(shown_text("plain"), "plain");
  EXPECT_EQ(shown_text("\x1b[31mA"), "\\x1b[31mA");
  const std::string big(10'000'000, 'x');
  EXPECT_EQ(shown_text(big), std::string(60, 'x') + "\u2026 (10000000 bytes)");
  // Cut at a character, not inside one: 100 × 'é' (2 bytes each) shows 60 of them.
  std::string e;
  for (int i = 0; i < 100; ++i) e += "\u00e9";
  std::string e60;
  for (int i = 0; i < 60; ++i) e60 += "\u00e9";
  EXPECT_EQ(shown_text(e), e60 + "\u2026 (200 bytes)");
}

TEST(ShownText, BadFieldsAndLabelsInErrorsAreCut) {
  const std::string big(10'000'000, 'x');
  const auto t = parse_csv("g,v\nA,1\nA," + big + "\nB,3\nB,4\n", "f.csv");
  const std::string e = error_of([&] { group_table(t, "v", "g", {}); });
  EXPECT_LT(e.size(), 300u) << e.substr(0, 300);
  EXPECT_NE(e.find("f.csv:3:3: column 'v' (field 2): expected a decimal number"), std::string::npos)
      << e.substr(0, 300);
  EXPECT_NE(e.find("'" + std::string(60, 'x') + "\u2026 (10000000 bytes)'"), std::string::npos);
  // A valid number too large is cut as well (its digits are echoed).
  const auto t2 = parse_csv("g,v\nA,1\nA,1" + std::string(1000, '0') + "\nB,3\nB,4\n", "f.csv");
  const std::string e2 = error_of([&] { group_table(t2, "v", "g", {}); });
  EXPECT_NE(e2.find("\u2026 (1001 bytes)'"), std::string::npos) << e2;
  EXPECT_LT(e2.size(), 300u) << e2;
  // A short bad field is echoed whole, as before.
  const auto t3 = parse_csv("g,v\nA,1\nA,abc\nB,3\nB,4\n", "f.csv");
  EXPECT_NE(error_of([&] { group_table(t3, "v", "g", {}); }).find("got 'abc'"), std::string::npos);
  // A group label of 5000 characters with a single value: cut in the message.
  const std::string label(5000, 'L');
  const auto t4 = parse_csv("g,v\n" + label + ",1\nB,3\nB,4\n", "f.csv");
  const std::string e4 = error_of([&] { group_table(t4, "v", "g", {}); });
  EXPECT_NE(e4.find("group '" + std::string(60, 'L') + "\u2026 (5000 bytes)'"), std::string::npos)
      << e4;
}

TEST(ShownText, LabelsInTextTablesAreEscapedAndTheSameInEveryRow) {
  const std::string label = "\x1b]0;pwned\x07" + std::string(600, 'G');
  const auto s = summarize_csv("g,v\n\"" + label + "\",1\n\"" + label + "\",2\nB,3\nB,4.5\n");
  const std::string text = to_text(s);
  EXPECT_EQ(text.find('\x1b'), std::string::npos);
  EXPECT_EQ(text.find('\x07'), std::string::npos);
  // Cut to its first 60 characters and its length (2026-12-06, eighth: 3 MB labels were printed
  // whole on every line), the same in every table row (a 512-byte buffer once cut the pair rows
  // silently), e.g. the pairwise row.
  const std::string shown = "\\x1b]0;pwned\\x07" + std::string(50, 'G') + "\u2026 (610 bytes)";
  EXPECT_NE(text.find("  " + shown + " - B "), std::string::npos) << text;
  EXPECT_NE(text.find("  " + shown + " vs B: t("), std::string::npos) << text;
  EXPECT_NE(text.find("Mann-Whitney " + shown + " vs B: W = "), std::string::npos) << text;
  // JSON keeps the label as it is (JSON escapes it itself).
  EXPECT_EQ(to_json(s)["groups"][0]["name"], label);
}

// parse_number and column_index cut what they echo themselves (callers other than group_table,
// e.g. calibrate, showed a 10 MB field whole), and the list of columns stops after 20.
TEST(ShownText, CsvReaderMessagesAreCut) {
  const std::string big(100'000, 'x');
  const auto t = parse_csv("g,v\nA," + big + "\n", "f.csv");
  const std::string e = error_of([&] { parse_number(t, 0, 1); });
  EXPECT_LT(e.size(), 300u) << e.substr(0, 300);
  EXPECT_NE(e.find("got '" + std::string(60, 'x') + "\u2026 (100000 bytes)'"), std::string::npos)
      << e.substr(0, 300);
  const auto t2 = parse_csv("g,v\nA,1" + std::string(500, '0') + "\n", "f.csv");
  const std::string e2 = error_of([&] { parse_number(t2, 0, 1); });
  EXPECT_NE(e2.find("got '1" + std::string(59, '0') + "\u2026 (501 bytes)'"), std::string::npos)
      << e2;
  // A long column name in the message of a bad field, with its control characters escaped.
  const std::string name = "\x1b[2J" + std::string(200, 'c');
  const auto t3 = parse_csv("g,\"" + name + "\"\nA,abc\n", "f.csv");
  const std::string e3 = error_of([&] { parse_number(t3, 0, 1); });
  EXPECT_NE(e3.find("column '\\x1b[2J" + std::string(56, 'c') + "\u2026 (204 bytes)' (field 2)"),
            std::string::npos)
      << e3;
  EXPECT_EQ(e3.find('\x1b'), std::string::npos) << e3;
  // column_index: the name asked for and each column cut, only the first 20 columns listed.
  std::string header;
  for (int c = 0; c < 500; ++c) header += (c ? ",c" : "c") + std::to_string(c);
  const auto wide = parse_csv(header + "\n" + std::string(499, ',') + "\n", "w.csv");
  const std::string e4 = error_of([&] { column_index(wide, std::string(5000, 'n')); });
  EXPECT_LT(e4.size(), 400u) << e4.substr(0, 400);
  EXPECT_NE(e4.find("no column '" + std::string(60, 'n') +
                    "\u2026 (5000 bytes)' in the header; "
                    "columns are: c0, c1, c2, c3, c4, c5, c6, c7, c8, c9, c10, c11, c12, c13, "
                    "c14, c15, c16, c17, c18, c19, \u2026 (500 columns)"),
            std::string::npos)
      << e4;
  const auto long_col = parse_csv("\"" + std::string(1000, 'h') + "\",v\n1,2\n", "f.csv");
  const std::string e5 = error_of([&] { column_index(long_col, "x"); });
  EXPECT_NE(e5.find("columns are: " + std::string(60, 'h') + "\u2026 (1000 bytes), v"),
            std::string::npos)
      << e5;
  EXPECT_EQ(shown_columns({"a", "b"}, "'"), "'a', 'b'");
  // A duplicate long column name is cut too.
  const std::string dup(300, 'd');
  const std::string e6 = error_of([&] { parse_csv(dup + "," + dup + "\n", "f.csv"); });
  EXPECT_NE(e6.find("duplicate column name '" + std::string(60, 'd') + "\u2026 (300 bytes)'"),
            std::string::npos)
      << e6;
}

// An adjusted p built from the 1e-300 bound is a bound itself: 3 × 1e-300 means p < 3e-300.
TEST(AdjustedP, HolmAndBonferroniOfABoundAreBounds) {
  std::vector<bool> hb, bb;
  const auto h = holm({kPFloor, 0.01, 0.04, NAN}, &hb);
  const auto b = bonferroni({kPFloor, 0.01, 0.04, NAN}, &bb);
  EXPECT_DOUBLE_EQ(h[0], 3e-300);
  EXPECT_DOUBLE_EQ(h[1], 0.02);
  EXPECT_DOUBLE_EQ(h[2], 0.04);
  EXPECT_TRUE(std::isnan(h[3]));
  EXPECT_EQ(hb, (std::vector<bool>{true, false, false, false}));
  EXPECT_DOUBLE_EQ(b[0], 3e-300);
  EXPECT_EQ(bb, (std::vector<bool>{true, false, false, false}));
  // Holm's running maximum: a bound term below an exact one is not a bound; two bounds are.
  const auto h2 = holm({kPFloor, kPFloor, 0.3}, &hb);
  EXPECT_DOUBLE_EQ(h2[0], 3e-300);
  EXPECT_DOUBLE_EQ(h2[1], 3e-300);  // max(3e-300, 2e-300): set by the first, a bound
  EXPECT_EQ(hb, (std::vector<bool>{true, true, false}));
  // An exact term below the bound's keeps the bound; one equal to it makes the value exact.
  const auto h3 = holm({kPFloor, 1.5e-300}, &hb);
  EXPECT_DOUBLE_EQ(h3[1], 2e-300);
  EXPECT_EQ(hb, (std::vector<bool>{true, true}));
  const auto h4 = holm({kPFloor, 2e-300}, &hb);
  EXPECT_EQ(h4[1], 2e-300);
  EXPECT_EQ(hb, (std::vector<bool>{true, false}));
  // Adjusted to 1: exact.
  bonferroni({kPFloor, 0.9}, &bb);
  EXPECT_EQ(bb, (std::vector<bool>{true, false}));
  EXPECT_EQ(holm({0.2, 0.6}), (std::vector<double>{0.4, 0.6}));  // no flags asked: unchanged

  // Through stats: A-B at the floor (t = -1.7e200, df 2), A-C and B-C (t ~ 1e100, df 2: p ~
  // 1e-200) exact.
  const StatsSummary s = summarize_csv(
      "g,v\nA,1e-100\nA,2e-100\nA,3e-100\nB,1e100\nB,1e100\nB,1e100\nC,1\nC,2\nC,4\n");
  const auto j = to_json(s);
  ASSERT_EQ(j["pairwise"].size(), 3u);
  const auto& pw = j["pairwise"][0];
  EXPECT_EQ(pw["p_is_bound"], true) << pw.dump();
  EXPECT_DOUBLE_EQ(pw["p_holm"].get<double>(), 3e-300) << pw.dump();
  EXPECT_EQ(pw["p_holm_is_bound"], true) << pw.dump();
  EXPECT_DOUBLE_EQ(pw["p_bonferroni"].get<double>(), 3e-300) << pw.dump();
  EXPECT_EQ(pw["p_bonferroni_is_bound"], true) << pw.dump();
  for (int i : {1, 2}) {
    EXPECT_EQ(j["pairwise"][i]["p_is_bound"], false) << j["pairwise"][i].dump();
    EXPECT_EQ(j["pairwise"][i]["p_holm_is_bound"], false) << j["pairwise"][i].dump();
    EXPECT_EQ(j["pairwise"][i]["p_bonferroni_is_bound"], false) << j["pairwise"][i].dump();
  }
  const std::string text = to_text(s);
  EXPECT_NE(text.find("< 1e-300   < 3e-300   < 3e-300"), std::string::npos) << text;
  EXPECT_EQ(format_p(3e-300, true), "< 3e-300");
  EXPECT_EQ(format_p(kPFloor, true), "< 1e-300");
  EXPECT_EQ(format_p(0.02, false), "0.02");
}

// Levene / Brown–Forsythe of spreads ~1e-170: MS_within ~ 3e-341 underflows a double to 0, so
// F (3.7e340) could not be recovered from the stored MS; oneway_anova keeps log F itself.
TEST(Overflow, LeveneWithMsWithinBelowADouble) {
  const StatsSummary s = summarize_csv("g,v\nA,0\nA,2\nB,0\nB,1e-170\nB,3e-170\n");
  // Levene deviations: A 1, 1; B (4, 1, 5)/3 · 1e-170. MS_between = 1.2, MS_within =
  // (78/81)/3 · 1e-340.
  EXPECT_EQ(s.levene.ms_within, 0.0);  // below the range of a double
  expect_rel(s.levene.log10_F, 340 + std::log10(1.2 * 81 / 26), 1e-12, "Levene log10 F");
  EXPECT_EQ(s.levene_log10_F, s.levene.log10_F);
  EXPECT_EQ(s.levene.p, kPFloor);
  // Brown–Forsythe: median deviations A 1, 1; B 1, 0, 2 · 1e-170; MS_within = 2e-340 / 3.
  expect_rel(s.brown_forsythe.log10_F, 340 + std::log10(1.2 * 3 / 2), 1e-12, "B-F log10 F");
  EXPECT_EQ(s.brown_forsythe.p, kPFloor);
  const auto j = to_json(s);
  EXPECT_TRUE(j["levene"]["F"].is_null());
  EXPECT_EQ(j["levene"]["p"], kPFloor);
  EXPECT_TRUE(j["levene"].contains("log10_F"));
  EXPECT_EQ(j["brown_forsythe"]["p"], kPFloor);
  EXPECT_NE(to_text(s).find("Levene (mean):           F(1, 3) = 3.74e+340, p < .001"),
            std::string::npos)
      << to_text(s);
  // An F within a double has no log10_F.
  EXPECT_TRUE(std::isnan(oneway_anova({{1, 2, 3}, {4, 5, 7}}).log10_F));
  // apa_anova prints the log F by itself.
  EXPECT_EQ(apa_anova(s.levene), "F(1, 3) = 3.74e+340, p < .001");
}

TEST(Apa, StatTextAndFText) {
  EXPECT_EQ(stat_text(1.7320508075688772e200, 2), "1.73e+200");
  EXPECT_EQ(stat_text(-12.3456, 3), "-12.346");
  EXPECT_EQ(stat_text(NAN, 3), "n/a");
  EXPECT_EQ(f_text(INFINITY, 400 + std::log10(3.0), 3), "3.000e+400");
  EXPECT_EQ(f_text(4.5, NAN, 3), "4.500");
}

// Values near 1e12 that differ by units: the descriptives printed mean, median and CI all as
// "1e+12" (review 2026-12-07); they get the digits that show a group's standard error, and the
// columns widen with them. Ordinary data keep five digits.
TEST(Descriptives, TextShowsLargeValuesToTheirSpread) {
  const auto s = summarize_csv(
      "g,v\nA,1000000000001\nA,1000000000002\nA,1000000000003\nB,1000000000011\nB,"
      "1000000000012\nB,1000000000014\n");
  const std::string text = to_text(s);
  EXPECT_NE(text.find(" 1000000000002 "), std::string::npos) << text;   // A's mean and median
  EXPECT_NE(text.find(" 1000000000012.3"), std::string::npos) << text;  // B's mean
  EXPECT_EQ(text.find("1e+12"), std::string::npos) << text;
  // Constant groups read back whole; groups 0.0005 apart near -1e12 are told apart.
  const std::string flat = to_text(summarize_csv(
      "g,v\nA,1000000000000.5\nA,1000000000000.5\nB,1000000000003.5\nB,1000000000003.5\n"));
  EXPECT_NE(flat.find(" 1000000000000.5 "), std::string::npos) << flat;
  EXPECT_EQ(flat.find("1e+12"), std::string::npos) << flat;
  const std::string near = to_text(
      summarize_csv("g,v\nA,-999999999999.9995\nA,-999999999999.9985\nA,-999999999999.9975\n"
                    "B,-999999999999.9990\nB,-999999999999.9980\nB,-999999999999.9970\n"));
  EXPECT_EQ(near.find("-1000000000000 "), std::string::npos) << near;
  const std::string small = to_text(summarize_csv("g,v\nA,2.51\nA,2.62\nA,2.43\nB,3.1\nB,2.9\n"));
  EXPECT_NE(small.find("  A                  3         2.52     0.095394 "), std::string::npos)
      << small;
}
