// CSV reader, exact decimal centring, p-value floor, APA formatting, p adjustments and
// distribution identities.
#include <gtest/gtest.h>

#include <gsl/gsl_sf_gamma.h>

#include <cmath>

#include "analysis/csv.hpp"
#include "analysis/decimal.hpp"
#include "analysis/descriptives.hpp"
#include "analysis/distributions.hpp"
#include "analysis/grouped.hpp"
#include "analysis/posthoc.hpp"
#include "analysis/summary.hpp"
#include "common/input_error.hpp"
#include "tests/analysis/support.hpp"

using namespace palplab::analysis;
using palplab::InputError;

TEST(Csv, QuotingCrLfBomAndEmbeddedNewlines) {
  auto t =
      parse_csv("\xEF\xBB\xBFgroup,\"va\"\"l\"\r\nA,1.5\r\n\"B, 2\",\"x\ny\"\r\n\nC,3", "f.csv");
  ASSERT_EQ(t.header.size(), 2u);
  EXPECT_EQ(t.header[0], "group");
  EXPECT_EQ(t.header[1], "va\"l");
  ASSERT_EQ(t.rows.size(), 3u);
  EXPECT_EQ(t.rows[1][0], "B, 2");
  EXPECT_EQ(t.rows[1][1], "x\ny");
  EXPECT_EQ(t.line[0], 2);
  EXPECT_EQ(t.line[1], 3);
  EXPECT_EQ(t.line[2], 6);  // the quoted newline and the blank line both count
  EXPECT_EQ(t.rows[2][1], "3");
  // Review (2026-12-06): blanks after the commas of a header ("participant, group") stayed in
  // the names ("no column 'group'"), and a second byte-order mark in the first one.
  const auto u =
      parse_csv("\xEF\xBB\xBF\xEF\xBB\xBFparticipant, group ,\tvalue\np1,A,1\n", "f.csv");
  EXPECT_EQ(u.header, (std::vector<std::string>{"participant", "group", "value"}));
  EXPECT_EQ(column_index(u, "group"), 1);
  EXPECT_NE(error_of([] { parse_csv("a, a\n1,2\n", "f.csv"); }).find("duplicate"),
            std::string::npos);
}

TEST(Csv, ErrorsCarryTheLine) {
  EXPECT_NE(error_of([] { parse_csv("a,b\n1,2\n3\n", "f.csv"); }).find("f.csv:3:"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_csv("a,b\n1,2\n\"3,4\n", "f.csv"); }).find("f.csv:3:"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_csv("a,b\n1,x\"y\n", "f.csv"); }).find("f.csv:2:"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_csv("a,a\n1,2\n", "f.csv"); }).find("duplicate"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_csv("", "f.csv"); }).find("header"), std::string::npos);
  EXPECT_NE(error_of([] { read_csv("/nonexistent/x.csv"); }).find("cannot open"),
            std::string::npos);
  auto t = parse_csv("g,v\nA,1\nA,abc\n", "f.csv");
  EXPECT_NE(error_of([&] { parse_number(t, 1, 1); }).find("f.csv:3:"), std::string::npos);
  EXPECT_NE(error_of([&] { column_index(t, "force"); }).find("no column 'force'"),
            std::string::npos);
}

TEST(Grouping, ValidatesAndFilters) {
  auto t = parse_csv("g,v,ph\nA,1,x\nA,2,y\nB,3,x\nB,4,x\nB,5,y\nC,6,y\n", "f.csv");
  // C has one value: error at its line (7).
  std::string e = error_of([&] { group_table(t, "v", "g", {}); });
  EXPECT_NE(e.find("f.csv:7:"), std::string::npos) << e;
  EXPECT_NE(e.find("group 'C'"), std::string::npos) << e;
  // Same column OR, rows of A and B only.
  auto g = group_table(t, "v", "g", {parse_where("g=A"), parse_where("g = B")});
  ASSERT_EQ(g.names.size(), 2u);
  EXPECT_EQ(g.values[1].size(), 3u);
  EXPECT_NEAR(g.offset + mean(g.values[1]), 4.0, 1e-15);
  EXPECT_NE(error_of([] { parse_where("novalue"); }).find("COLUMN=VALUE"), std::string::npos);
  EXPECT_NE(error_of([&] { group_table(t, "v", "g", {parse_where("zz=1")}); }).find("no column"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              group_table(t, "v", "g", {parse_where("ph=none")});
            }).find("matches --where ph=none"),
            std::string::npos);
  // Only one group left after filtering.
  EXPECT_NE(error_of([&] { group_table(t, "v", "g", {parse_where("g=B")}); }).find("at least 2"),
            std::string::npos);
}

TEST(Decimal, ExactCentring) {
  auto d = parse_decimal(" -12.500e-3 ");
  ASSERT_TRUE(d);
  EXPECT_EQ(static_cast<long long>(d->mantissa), -12500);
  EXPECT_EQ(d->exponent, -6);
  EXPECT_FALSE(parse_decimal("1.2.3"));
  EXPECT_FALSE(parse_decimal("abc"));
  // In double, 1000000000000.4 - 1000000000000.1 = 0.2998046875; exactly it is 0.3.
  EXPECT_EQ(decimal_difference("1000000000000.4", "1000000000000.1"), 0.3);
  EXPECT_EQ(decimal_difference("1e12", "999999999999.9"), 0.1);
  auto c = centre_decimals({"10000000.2", "10000000.1", "10000000.3"});
  EXPECT_EQ(c.dev[1], -0.1);
  EXPECT_EQ(c.dev[2], 0.1);
  EXPECT_DOUBLE_EQ(c.centre, 10000000.2);
}

TEST(PValues, UnderflowIsABoundNeverZero) {
  double p = t_two_sided_p(1e4, 1000);
  EXPECT_GT(p, 0);
  EXPECT_TRUE(p_is_bound(p));
  EXPECT_EQ(format_p(p), "< 1e-300");
  EXPECT_FALSE(p_is_bound(t_two_sided_p(3, 10)));
  // Two-sided t p through F agrees with the t distribution's own closed form at df = 1
  // (Cauchy: p = 1 - 2 atan(|t|)/π) and df = 2 (p = 1 - |t|/sqrt(2 + t²)).
  for (double t : {0.3, 1.0, 4.0, 50.0}) {
    EXPECT_NEAR(t_two_sided_p(t, 1), 1 - 2 * std::atan(t) / M_PI, 1e-15);
    double r = std::sqrt(2 + t * t), p2 = 2 / (r * (r + t));  // = 1 - t/r without cancellation
    EXPECT_NEAR(t_two_sided_p(t, 2), p2, 1e-13 * p2);
  }
  // df = 2: t_p = (2p - 1) sqrt(2 / (1 - (2p - 1)²)).
  EXPECT_NEAR(t_quantile(0.975, 2), 0.95 * std::sqrt(2 / (1 - 0.95 * 0.95)), 1e-12);
}

TEST(Apa, Formatting) {
  EXPECT_EQ(apa_p(0.0034), "p = .003");
  EXPECT_EQ(apa_p(0.00049), "p < .001");
  EXPECT_EQ(apa_p(0.9999), "p > .999");
  EXPECT_EQ(apa_f(23.6812, 2, 27, 1e-6), "F(2, 27) = 23.68, p < .001");
  EXPECT_EQ(apa_t(3.4321, 17, 0.0031), "t(17) = 3.43, p = .003");
  EXPECT_EQ(apa_t(-2.1, 13.564, 0.05), "t(13.56) = -2.10, p = .050");
}

TEST(Adjust, HolmAndBonferroniAsRPAdjust) {
  std::vector<double> p{0.01, 0.04, 0.03, 0.005};
  auto h = holm(p), b = bonferroni(p);
  std::vector<double> he{0.03, 0.06, 0.06, 0.02}, be{0.04, 0.16, 0.12, 0.02};
  for (size_t i = 0; i < p.size(); ++i) {
    EXPECT_NEAR(h[i], he[i], 1e-15);
    EXPECT_NEAR(b[i], be[i], 1e-15);
  }
}

TEST(NoncentralT, ReducesToCentralAndIsMonotone) {
  for (double nu : {3.0, 12.0, 80.0})
    for (double t : {0.2, 1.5, 4.0}) {
      double central = 1 - 0.5 * t_two_sided_p(t, nu);
      EXPECT_NEAR(noncentral_t_cdf(t, nu, 0), central, 1e-13) << nu << " " << t;
    }
  EXPECT_GT(noncentral_t_cdf(1.0, 10, 0.5), noncentral_t_cdf(1.0, 10, 1.0));
  double d = noncentral_t_delta_for_cdf(2.0, 15, 0.3);
  EXPECT_NEAR(noncentral_t_cdf(2.0, 15, d), 0.3, 1e-12);
}

// The noncentral F sum: λ = 0 is the central F (GSL, 5e-15: a few ulps of 1 - p); the truncated
// sum equals the untruncated one (every Poisson term from j = 0 to far beyond the mode, in long
// double) to 5e-15 absolute (GSL beta rounding), so the truncation bound holds; the CDF falls with
// λ; the λ root reproduces its probability.
TEST(NoncentralF, CentralLimitTruncationAndInversion) {
  for (double d1 : {1.0, 3.0, 9.5})
    for (double d2 : {2.5, 30.0, 4000.0})
      for (double x : {0.01, 0.7, 3.0, 25.0})
        EXPECT_NEAR(noncentral_f_cdf(x, d1, d2, 0), 1 - f_upper_p(x, d1, d2), 5e-15)
            << d1 << " " << d2 << " " << x;
  double worst = 0;
  for (double d1 : {1.0, 4.0, 17.0})
    for (double d2 : {3.0, 60.0})
      for (double lambda : {0.3, 9.0, 150.0, 2500.0})
        for (double x : {0.2, 1.0, 4.0, 60.0}) {
          const double mu = lambda / 2, y = d1 * x / (d1 * x + d2);
          long double full = 0;
          const int jmax = static_cast<int>(mu + 60 * std::sqrt(mu) + 300);
          for (int j = 0; j <= jmax; ++j)
            full +=
                std::exp(static_cast<long double>(j * std::log(mu) - mu - std::lgamma(j + 1.0))) *
                gsl_sf_beta_inc(d1 / 2 + j, d2 / 2, y);
          const double got = noncentral_f_cdf(x, d1, d2, lambda);
          worst = std::max(worst, std::fabs(got - static_cast<double>(full)));
          EXPECT_NEAR(got, static_cast<double>(full), 5e-15)
              << d1 << " " << d2 << " " << lambda << " " << x;
        }
  std::printf("[ ncF      ] truncated vs full sum: max abs difference %.2e\n", worst);
  double prev = 1;
  for (double lambda = 0; lambda < 200; lambda += 7.5) {
    const double c = noncentral_f_cdf(2.5, 3, 40, lambda);
    EXPECT_LT(c, prev);
    prev = c;
  }
  const double l = noncentral_f_lambda_for_cdf(4.2, 2, 27, 0.025);
  EXPECT_NEAR(noncentral_f_cdf(4.2, 2, 27, l), 0.025, 1e-13);
  EXPECT_EQ(noncentral_f_lambda_for_cdf(0.3, 2, 27, 0.975), 0);  // λ = 0 already below
  // A small F: the lower bound sits at 0, the interval still has a positive upper bound.
  FEffectCi c = f_effect_ci(0.3, 2, 27);
  ASSERT_TRUE(c.defined);
  EXPECT_EQ(c.lambda_low, 0);
  EXPECT_EQ(c.pve_low, 0);
  EXPECT_GT(c.pve_high, 0);
  EXPECT_LT(c.pve_high, 1);
  EXPECT_FALSE(f_effect_ci(INFINITY, 2, 27).defined);
  EXPECT_FALSE(f_effect_ci(1e18, 2, 27).defined);
  EXPECT_THROW(noncentral_f_cdf(1, 0, 3, 1), std::invalid_argument);
}

// Review findings: strtod's ERANGE on underflow rejected valid subnormals such as 1e-320; a
// directory was "empty CSV file"; 50 000 groups allocated 1.25e9 pairs (bad_alloc, exit 3).
TEST(Csv, SubnormalAndUnderflowingValuesAreNumbers) {
  auto t = parse_csv("g,v\nA,1e-320\nA,-4.9e-324\nA,1e-400\nA,1e309\n", "f.csv");
  EXPECT_EQ(parse_number(t, 0, 1), 1e-320);
  EXPECT_EQ(parse_number(t, 1, 1), -4.9e-324);
  EXPECT_EQ(parse_number(t, 2, 1), 0.0);  // below the smallest double: rounds to 0
  const std::string e = error_of([&] { parse_number(t, 3, 1); });  // overflow stays an error
  EXPECT_NE(e.find("f.csv:5:3:"), std::string::npos) << e;
  EXPECT_NE(e.find("range of a double"), std::string::npos) << e;
}

// ... but data whose spread is below 1e-150 cannot be squared: they gave SD 0 beside F = 5.
TEST(Grouping, ASpreadBelowTheSquarableRangeIsRefused) {
  auto t = parse_csv("g,v\nA,1e-200\nA,2e-200\nB,3e-200\nB,5e-200\n", "f.csv");
  const std::string e = error_of([&] { group_table(t, "v", "g", {}); });
  EXPECT_NE(e.find("f.csv: column 'v': the values used differ from 0 by at most 5e-200: below "
                   "1e-150"),
            std::string::npos)
      << e;
  // Tiny values beside ordinary ones, and constant data (no spread), are analysed.
  EXPECT_EQ(
      group_table(parse_csv("g,v\nA,1e-320\nA,1\nB,2\nB,3\n", "f.csv"), "v", "g", {}).rows_used, 4);
  EXPECT_EQ(
      group_table(parse_csv("g,v\nA,1e-200\nA,1e-200\nB,1e-200\nB,1e-200\n", "f.csv"), "v", "g", {})
          .rows_used,
      4);
}

TEST(Csv, ADirectoryIsNamedAsOne) {
  const std::string e = error_of([] { read_csv(PALPLAB_SOURCE_DIR); });
  EXPECT_NE(e.find("is a directory, expected a CSV file"), std::string::npos) << e;
}

TEST(Grouping, TooManyGroupsAreRefusedBeforeTheAnalysis) {
  auto many = [](int k) {
    std::string csv = "g,v\n";
    for (int i = 0; i < k; ++i)
      csv += "G" + std::to_string(i) + ",1\nG" + std::to_string(i) + ",2\n";
    return parse_csv(csv, "f.csv");
  };
  EXPECT_EQ(group_table(many(100), "v", "g", {}).names.size(), 100u);  // the limit itself
  const std::string e = error_of([&] { group_table(many(101), "v", "g", {}); });
  EXPECT_NE(e.find("f.csv: column 'g' has 101 groups"), std::string::npos) << e;
  EXPECT_NE(e.find("at most 100"), std::string::npos) << e;
  EXPECT_NE(e.find("5050 pairs"), std::string::npos) << e;
  // The review's file: 50 000 groups of 2 (1.25e9 pairs) ended in bad_alloc after 22 GB.
  EXPECT_NE(error_of([&] { group_table(many(50000), "v", "g", {}); }).find("has 50000 groups"),
            std::string::npos);
}
