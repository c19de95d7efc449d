// Speed of the statistics: studentized range CDF / upper tail / quantile (the cost behind
// Tukey–Kramer and Games–Howell), the noncentral-t interval of Cohen's d, and the whole
// one-way summary of `palplab stats` (3 groups × 40, as experiment 1 pools). Prints medians of
// repeated runs and the ratio of the summary with and without the post-hoc tests.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>
#include <vector>

#include "analysis/distributions.hpp"
#include "analysis/summary.hpp"
#include "analysis/two_sample.hpp"

using namespace palplab::analysis;

template <class F>
double median_ms(F f, int reps) {
  std::vector<double> t;
  for (int r = 0; r < reps; ++r) {
    auto a = std::chrono::steady_clock::now();
    f();
    auto b = std::chrono::steady_clock::now();
    t.push_back(std::chrono::duration<double, std::milli>(b - a).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

int main() {
  volatile double sink = 0;
  struct Case {
    double q;
    int k;
    double df;
  };
  std::printf("studentized range (median of 9 runs)\n");
  for (Case c : {Case{1.0, 3, 10}, Case{3.5, 3, 27}, Case{4.0, 10, 50}, Case{0.1, 20, 120},
                 Case{10.0, 20, 3}}) {
    double cdf = median_ms([&] { sink = sink + studentized_range_cdf(c.q, c.k, c.df); }, 9);
    double sf = median_ms([&] { sink = sink + studentized_range_sf(c.q, c.k, c.df); }, 9);
    std::printf("  q=%5.2f k=%2d df=%4g   cdf %7.2f ms   sf %7.2f ms\n", c.q, c.k, c.df, cdf, sf);
  }
  double fp = median_ms([&] { sink = sink + f_upper_p(4.2, 2, 27) + t_two_sided_p(3.1, 17.3); }, 9);
  std::printf("  F and t p-values (one of each): %.3f ms\n", fp);
  double qt = median_ms([] { (void)studentized_range_quantile(0.95, 3, 27); }, 5);
  std::printf("  quantile p=.95 k=3 df=27: %.1f ms\n", qt);

  std::mt19937_64 rng(7);
  std::normal_distribution<double> n01(0, 1);
  GroupedData d;
  d.names = {"A", "B", "C"};
  d.values.assign(3, {});
  for (int g = 0; g < 3; ++g)
    for (int i = 0; i < 40; ++i) d.values[g].push_back(2.5 + 0.2 * g + 0.4 * (g + 1) * n01(rng));
  double es = median_ms([&] { sink = sink + cohens_d(d.values[0], d.values[1]).d_ci_low; }, 9);
  std::printf("\nCohen's d with noncentral-t 95%% CI (n = 40 + 40): %.2f ms\n", es);
  StatsOptions full, lite;
  lite.post_hoc = false;
  double t_full = median_ms([&] { sink = sink + summarize(d, full).anova.F; }, 5);
  double t_lite = median_ms([&] { sink = sink + summarize(d, lite).anova.F; }, 5);
  std::printf(
      "one-way summary, 3 groups x 40: %.1f ms with Tukey + Games-Howell, %.1f ms without"
      " (ratio %.1f)\n",
      t_full, t_lite, t_full / t_lite);
  return 0;
}
