#pragma once
// Descriptive statistics of one sample. Sums run in long double and variances are two-pass
// (Σ(x - x̄)² with a compensated correction term), so data with many constant leading digits
// keep their precision (NIST StRD NumAcc4: ~15 digits after decimal centring, see decimal.hpp).
#include <string>
#include <vector>

namespace palplab::analysis {

// x  #x values; all functions taking x expect x.size() >= 1 unless noted.
long double mean_ld(const std::vector<double>& x);
// Sum of squared deviations from the mean, Σ(x_i - x̄)² (two-pass, corrected).
long double sum_sq_dev(const std::vector<double>& x);
double mean(const std::vector<double>& x);
// Sample variance / SD with denominator n - 1 (NaN when n < 2).
double variance(const std::vector<double>& x);
double sd(const std::vector<double>& x);
double median(std::vector<double> x);
// Quantile by linear interpolation of the order statistics (R's default, type 7): the value
// at position (n - 1)·p of the sorted sample.
double quantile(std::vector<double> x, double p);

struct Descriptives {
  int n = 0;
  double mean = 0, sd = 0, se = 0;             // sd with n - 1; se = sd / sqrt(n)
  double median = 0, q1 = 0, q3 = 0, iqr = 0;  // quartiles type 7
  double min = 0, max = 0;
  double ci_low = 0, ci_high = 0;  // confidence interval of the mean, t with n - 1 df
  double ci_level = 0.95;
};

// `offset` is added to every location statistic (mean, median, quartiles, min, max, CI): the
// caller may pass deviations from a centre (decimal.hpp) and get back the original scale.
Descriptives describe(const std::vector<double>& x, double offset = 0, double ci_level = 0.95);

// Wilson score interval of a proportion k/n (Wilson 1927): always inside [0, 1], unlike the
// Wald or t interval, and with near-nominal coverage for small n. n >= 1, 0 <= k <= n.
struct ProportionInterval {
  double p = 0, low = 0, high = 0;
};
ProportionInterval wilson_interval(int k, int n, double level = 0.95);

}  // namespace palplab::analysis
