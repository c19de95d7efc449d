// The speed-ups of `palplab stats` (issue 13) change no result: the summary computed on 2
// threads equals the serial one to the last bit, the merge-based Mann–Whitney equals the
// pooled mid-rank computation, the point values of the Welch effect size equal the pooled
// ones, and the noncentral t CDF is the same from either side (its lower tail is integrated
// first where the CDF is small, the upper tail first otherwise).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "analysis/anova.hpp"
#include "analysis/distributions.hpp"
#include "analysis/parallel.hpp"
#include "analysis/posthoc.hpp"
#include "analysis/summary.hpp"
#include "analysis/two_sample.hpp"

using namespace palplab::analysis;

namespace {
// 12 groups of 40-70 values rounded to 0.1 (ties within and across groups), means and SDs
// differing by group.
GroupedData sample_data() {
  std::mt19937_64 rng(13);
  std::normal_distribution<double> n01(0, 1);
  GroupedData d;
  d.value_column = "v";
  d.group_column = "g";
  for (int g = 0; g < 12; ++g) {
    d.names.push_back("G" + std::to_string(g));
    std::vector<double> x;
    const int n = 40 + 3 * g;
    for (int i = 0; i < n; ++i)
      x.push_back(std::round(10 * (5 + 0.2 * g + (1 + 0.1 * g) * n01(rng))) / 10);
    d.values.push_back(x);
    d.lines.push_back(std::vector<int>(x.size(), 2));
  }
  return d;
}

struct ThreadsGuard {
  explicit ThreadsGuard(unsigned n) : old(analysis_threads().load()) { analysis_threads() = n; }
  ~ThreadsGuard() { analysis_threads() = old; }
  unsigned old;
};
}  // namespace

TEST(ParallelStats, SummaryOnTwoThreadsEqualsSerial) {
  const GroupedData d = sample_data();
  StatsOptions opt;
  opt.margins = std::make_pair(-0.5, 0.5);
  std::string serial, parallel;
  {
    ThreadsGuard g(1);
    serial = to_json(summarize(d, opt)).dump();
  }
  {
    ThreadsGuard g(2);
    parallel = to_json(summarize(d, opt)).dump();
  }
  EXPECT_EQ(serial, parallel);
  EXPECT_GT(serial.size(), 10000u);  // 66 pairs of every test
}

TEST(ParallelStats, ExceptionOfTheLowestIndexIsRethrown) {
  ThreadsGuard g(2);
  try {
    parallel_for(100, [](size_t i) {
      if (i == 37 || i == 90) throw std::runtime_error(std::to_string(i));
    });
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "37");
  }
}

TEST(ParallelStats, MergedMannWhitneyEqualsPooledMidranks) {
  const GroupedData d = sample_data();
  for (size_t a = 0; a + 1 < d.values.size(); ++a) {
    const auto &x = d.values[a], &y = d.values[a + 1];
    std::vector<double> all = x;
    all.insert(all.end(), y.begin(), y.end());
    double ties = 0;
    const auto r = midranks(all, &ties);
    long double rs = 0;
    for (size_t i = 0; i < x.size(); ++i) rs += r[i];
    const double na = x.size(), nb = y.size(), n = na + nb;
    const double w = static_cast<double>(rs - na * (na + 1) / 2);
    const double z0 = w - na * nb / 2;
    const double sigma = std::sqrt(na * nb / 12 * ((n + 1) - ties / (n * (n - 1))));
    const double z = (z0 - (z0 > 0 ? 0.5 : (z0 < 0 ? -0.5 : 0))) / sigma;
    const MannWhitney mw = mann_whitney(x, y);
    EXPECT_GT(ties, 0);
    EXPECT_FALSE(mw.exact);
    EXPECT_EQ(mw.W, w) << a;
    EXPECT_EQ(mw.z, z) << a;
    EXPECT_EQ(mw.p, normal_two_sided_p(z)) << a;
  }
  // Small samples without ties: the exact test, on the same W.
  const MannWhitney small = mann_whitney({1.5, 3.25, 0.5, 7}, {2, 4, 8, 9, 10});
  EXPECT_TRUE(small.exact);
  EXPECT_EQ(small.W, 3.0);  // a's values below b's: 1.5 (1), 3.25 (2), 7 (0), 0.5 (0)
}

TEST(ParallelStats, WelchEffectSizeKeepsThePooledPointValues) {
  const GroupedData d = sample_data();
  const auto &x = d.values[0], &y = d.values[7];
  const EffectSize pooled = cohens_d(x, y);
  const TTest w = welch_t(x, y);
  const EffectSize welch = cohens_d_welch(x, y, w);
  EXPECT_EQ(welch.d, pooled.d);
  EXPECT_EQ(welch.g, pooled.g);
  EXPECT_STREQ(welch.ci_method, "welch");
  EXPECT_LT(welch.d_ci_low, welch.d);
  EXPECT_GT(welch.d_ci_high, welch.d);
  // The moments alone are welch_t's.
  const TTest m = welch_t_moments(x, y);
  EXPECT_EQ(m.mean_diff, w.mean_diff);
  EXPECT_EQ(m.se, w.se);
  EXPECT_EQ(m.df_exact, w.df_exact);
}

TEST(ParallelStats, NoncentralTFromEitherTail) {
  // T(δ) = -T(-δ): P(T <= t; δ) = 1 - P(T <= -t; -δ). Small CDFs take the lower-tail-first
  // path, their mirror images the upper-tail-first one.
  for (double df : {3.0, 30.0, 6600.0})
    for (double t : {-2.0, 0.5, 4.0})
      for (double shift : {1.5, 3.0, 6.0}) {
        const double delta = t + shift;  // CDF well below 1/2
        const double lo = noncentral_t_cdf(t, df, delta);
        const double mirror = 1 - noncentral_t_cdf(-t, df, -delta);
        EXPECT_LT(lo, 0.45);
        EXPECT_NEAR(lo, mirror, 1e-12 + 1e-9 * lo) << df << " " << t << " " << delta;
      }
}
