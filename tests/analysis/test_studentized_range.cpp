// Our studentized range distribution against mpmath (tests/data/studentized-range, 72 CDF
// cases at atol = rtol = 1e-11, as scipy tests it) and against closed forms for k = 2.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "analysis/distributions.hpp"
#include "analysis/posthoc.hpp"

using namespace palplab::analysis;

TEST(StudentizedRange, MpmathReferenceCdf) {
  std::ifstream in(std::string(PALPLAB_SOURCE_DIR) +
                   "/tests/data/studentized-range/studentized_range_mpmath_ref.json");
  ASSERT_TRUE(in.good());
  auto j = nlohmann::json::parse(in);
  const auto& cases = j.at("cdf_data");
  ASSERT_EQ(cases.size(), 72u);
  double worst_abs = 0, worst_rel_big = 0;
  for (const auto& c : cases) {
    double q = c["src_case"]["q"], v = c["src_case"]["v"];
    int k = c["src_case"]["k"];
    double atol = c["src_case"]["expected_atol"], rtol = c["src_case"]["expected_rtol"];
    double ref = c["mp_result"];
    double cdf = studentized_range_cdf(q, k, v);
    double sf = studentized_range_sf(q, k, v);
    EXPECT_LE(std::fabs(cdf - ref), atol + rtol * std::fabs(ref))
        << "q=" << q << " k=" << k << " v=" << v << " cdf=" << cdf << " ref=" << ref;
    // The upper tail is computed separately (no 1 - cdf): it must complement the reference.
    EXPECT_LE(std::fabs(sf - (1 - ref)), atol + rtol * std::fabs(1 - ref))
        << "q=" << q << " k=" << k << " v=" << v << " sf=" << sf;
    worst_abs = std::max(worst_abs, std::fabs(cdf - ref));
    // Relative error where the reference itself has full relative accuracy (values > 1e-20:
    // for k = 20, q = 0.1 the scipy/mpmath values, 1e-22 ... 5e-28, even fall below the ν = ∞
    // limit, which is impossible; an independent mpmath run agrees with us, see the next test).
    if (ref > 1e-20) worst_rel_big = std::max(worst_rel_big, std::fabs(cdf - ref) / ref);
  }
  std::printf("[ SRANGE   ] 72 CDF cases: max abs error %.2e, max rel error (ref > 1e-20) %.2e\n",
              worst_abs, worst_rel_big);
  EXPECT_LT(worst_rel_big, 1e-11);
}

// The k = 20, q = 0.1 lower tails, recomputed with mpmath at 30 digits
// (tests/data/studentized-range/check_k20_mpmath.py and .out), to 1e-11 relative.
TEST(StudentizedRange, TinyLowerTailsAgainstIndependentMpmath) {
  struct C {
    double nu, ref;
  };
  for (C c : {C{3, 9.53977219531843e-22}, C{120, 2.19817268156832e-26},
              C{INFINITY, 1.1588437168132e-26}}) {
    double got = studentized_range_cdf(0.1, 20, c.nu);
    EXPECT_NEAR(got, c.ref, 1e-11 * c.ref) << "nu=" << c.nu;
    std::printf("[ SRANGE   ] k=20 q=0.1 nu=%g: %.15g (mpmath %.15g, rel %.1e)\n", c.nu, got, c.ref,
                std::fabs(got - c.ref) / c.ref);
  }
}

// k = 2: Q = |Z1 - Z2| / S = sqrt(2)|T_ν|, so P(Q > q) = P(F(1, ν) > q²/2); ν = ∞: erfc(q/2).
TEST(StudentizedRange, TwoMeansClosedForm) {
  for (double nu : {0.5, 1.0, 1.3, 2.0, 5.0, 17.5, 60.0, 1000.0, 1e6})
    for (double q : {1e-6, 0.05, 0.5, 2.0, 4.0, 8.0, 40.0}) {
      double expect = t_two_sided_p(q / std::sqrt(2.0), nu);
      double got = studentized_range_sf(q, 2, nu);
      EXPECT_NEAR(got, expect, 1e-11 * expect) << "nu=" << nu << " q=" << q;
      // The lower tail, computed separately, complements it.
      EXPECT_NEAR(studentized_range_cdf(q, 2, nu), 1 - expect, 1e-12) << "nu=" << nu << " q=" << q;
    }
  for (double q : {0.05, 0.5, 2.0, 4.0, 12.0}) {
    double expect = std::erfc(q / 2);
    EXPECT_NEAR(studentized_range_sf(q, 2, INFINITY), expect, 1e-13 * expect) << q;
  }
}

// Far beyond the s-grid (q = 1e11 gave 0 for ν = 1 and NaN for ν = 4: Tukey's p of groups
// 1e-11 apart fell to the 1e-300 floor while the ANOVA's was 2.7e-44, review 2026-12-07).
// k = 2 in closed form, x = q/√2: ν = 1, P(|T| > x) = (2/π) atan(1/x); ν = 2,
// P(|T| > x) = 2 / (√(2+x²) (√(2+x²) + x)). For k = 3 the tail falls exactly like q^-ν where
// e^(-ν s²/2) ≈ 1 over s ~ 1/q, and it is continuous where the far-tail integral takes over
// (q = 1e8).
TEST(StudentizedRange, HugeQFollowsTheClosedFormAndTheTailLaw) {
  for (double q : {1e6, 1e8, 3e9, 1e11, 1e13, 1e20, 1e100, 1e250}) {
    const double x = q / std::sqrt(2.0);
    const long double one = 2 / std::acos(-1.0L) * std::atan(1 / static_cast<long double>(x));
    EXPECT_NEAR(studentized_range_sf(q, 2, 1.0), one, 1e-9 * one) << q;
    if (q > 1e140) continue;  // ν = 2 below the double range
    const long double r = std::sqrt(2 + static_cast<long double>(x) * x);
    const long double two = 2 / (r * (r + x));
    EXPECT_NEAR(studentized_range_sf(q, 2, 2.0), two, 1e-9 * two) << q;
  }
  for (double nu : {0.5, 4.0, 12.0})
    for (double q : {1e9, 1e11, 1e14}) {
      const double a = studentized_range_sf(q, 3, nu), b = studentized_range_sf(10 * q, 3, nu);
      ASSERT_GT(b, 0) << nu << " " << q;
      EXPECT_NEAR(b / a, std::pow(10.0, -nu), 1e-8 * std::pow(10.0, -nu)) << nu << " " << q;
    }
  for (double nu : {0.5, 4.0, 1000.0})
    for (int k : {3, 20}) {
      const double below = studentized_range_sf(1e8 * (1 - 1e-9), k, nu),
                   above = studentized_range_sf(1e8 * (1 + 1e-9), k, nu);
      EXPECT_NEAR(above, below, 1e-7 * below) << nu << " " << k;
    }
}

TEST(StudentizedRange, QuantileInvertsCdf) {
  for (int k : {2, 3, 10})
    for (double nu : {3.0, 27.0, 120.0})
      for (double p : {0.5, 0.95, 0.99}) {
        double q = studentized_range_quantile(p, k, nu);
        EXPECT_NEAR(studentized_range_cdf(q, k, nu), p, 1e-12) << k << " " << nu << " " << p;
      }
}

// Extreme arguments stay finite, complementary and fast (a regression: a jittering inner
// integrand for q = 1e-8 once made the adaptive rule exhaust its budget for ~90 s).
TEST(StudentizedRange, ExtremeArguments) {
  struct C {
    double q;
    int k;
    double nu;
  };
  for (C c : {C{1e-8, 3, 10}, C{1e4, 3, 10}, C{200, 3, 100}, C{3, 3, 0.5}, C{3, 3, 1e6},
              C{3, 100, 20}, C{30, 100, 20}, C{0.5, 100, 20}}) {
    double lo = studentized_range_cdf(c.q, c.k, c.nu), up = studentized_range_sf(c.q, c.k, c.nu);
    EXPECT_TRUE(std::isfinite(lo) && std::isfinite(up)) << c.q << " " << c.k << " " << c.nu;
    EXPECT_NEAR(lo + up, 1.0, 1e-12) << c.q << " " << c.k << " " << c.nu;
  }
}

TEST(StudentizedRange, TinyUpperTailKeepsRelativeAccuracy) {
  // k = 2 again, deep in the tail: the direct upper-tail integral must not be 1 - cdf.
  double expect = t_two_sided_p(30 / std::sqrt(2.0), 40);
  double got = studentized_range_sf(30, 2, 40);
  ASSERT_GT(expect, 0);
  EXPECT_NEAR(got, expect, 1e-9 * expect);
}

// Far upper tail against an independent mpmath computation (30 digits, no underflow:
// tests/data/studentized-range/far_tail_mpmath.py and .out). Every value >= 1e-300 (the
// reporting floor kPFloor) must keep 1e-9 relative accuracy; values below it must be reported
// as the bound. q = 89.5, k = 9, ν = 4000 (SmLs09's Games–Howell) once cost 68 s.
TEST(StudentizedRange, FarUpperTailAgainstMpmath) {
  std::ifstream in(std::string(PALPLAB_SOURCE_DIR) +
                   "/tests/data/studentized-range/far_tail_mpmath.out");
  ASSERT_TRUE(in.good());
  std::string line;
  int n = 0, below = 0;
  double worst = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    double q, nu;
    int k;
    std::string ref_text;
    ASSERT_TRUE(static_cast<bool>(ss >> q >> k >> nu >> ref_text)) << line;
    // The reference may be far below the double range: compare in log10 via the text.
    long double ref = std::strtold(ref_text.c_str(), nullptr);
    double got = studentized_range_sf(q, k, nu);
    ++n;
    if (ref < 1e-300L) {
      ++below;
      EXPECT_TRUE(p_is_bound(clamp_p(got))) << line << " got " << got;
      continue;
    }
    double rel = static_cast<double>(std::fabs(got - ref) / ref);
    worst = std::max(worst, rel);
    EXPECT_LT(rel, 1e-9) << line << " got " << got;
  }
  EXPECT_GE(n, 9);
  EXPECT_GE(below, 1);
  std::printf("[ SRANGE   ] far tail: %d values (%d below 1e-300), max rel error %.1e\n", n, below,
              worst);
}

// Games–Howell critical values: interpolated over the pairs' df, they agree with the root of
// each df solved on its own.
TEST(StudentizedRange, CriticalValuesInterpolatedOverDf) {
  std::vector<double> dfs;
  for (int i = 0; i < 40; ++i) dfs.push_back(6.5 + 3.7 * i + 0.01 * i * i);
  RangeQuantiles qc(0.95, 6, dfs);
  EXPECT_TRUE(qc.interpolated());
  for (double df : {7.3, 23.9, 61.2, 130.0, 151.4}) {
    double exact = studentized_range_quantile(0.95, 6, df);
    EXPECT_NEAR(qc(df), exact, 1e-10 * exact) << df;
  }
  // Welch df equal up to rounding (SmLs09: 36 pairs at ~4000): no NaN, agrees with the root.
  std::vector<double> near;
  for (int i = 0; i < 36; ++i) near.push_back(4000 * (1 + 1e-13 * i));
  RangeQuantiles nq(0.95, 9, near);
  EXPECT_NEAR(nq(near[17]), studentized_range_quantile(0.95, 9, near[17]), 1e-12);
  // The df of groups of 2 and 3 (Welch's ν between 1 and 4; review 2026-12-06, seventh: 100
  // groups of 2 solved 4950 roots one by one and took over 15 minutes): interpolated in log q,
  // the same values as the roots.
  for (int k : {6, 100}) {
    std::vector<double> small;
    for (int i = 0; i < 60; ++i) small.push_back(1.02 + 0.049 * i + 1e-4 * i * i);
    RangeQuantiles sq(0.95, k, small);
    EXPECT_TRUE(sq.interpolated()) << k;
    for (double df : {1.03, 1.5, 2.2, 3.3}) {
      double exact = studentized_range_quantile(0.95, k, df);
      EXPECT_NEAR(sq(df), exact, 1e-10 * exact) << k << " " << df;
    }
  }
  // Few distinct df: each solved directly.
  RangeQuantiles few(0.95, 3, {10, 20, 20, 30});
  EXPECT_FALSE(few.interpolated());
  EXPECT_NEAR(few(20), studentized_range_quantile(0.95, 3, 20), 1e-13);
}
