#include "analysis/descriptives.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <gsl/gsl_cdf.h>

#include "analysis/distributions.hpp"

namespace palplab::analysis {

long double mean_ld(const std::vector<double>& x) {
  if (x.empty()) return std::numeric_limits<long double>::quiet_NaN();
  long double s = 0;
  for (double v : x) s += v;
  long double m = s / x.size();
  // One correction pass: the mean of the residuals removes the rounding of the first sum.
  long double c = 0;
  for (double v : x) c += v - m;
  return m + c / x.size();
}

long double sum_sq_dev(const std::vector<double>& x) {
  long double m = mean_ld(x);
  long double ss = 0, s = 0;
  for (double v : x) {
    long double d = v - m;
    ss += d * d;
    s += d;
  }
  // Corrected two-pass (Chan, Golub & LeVeque): subtract the residual mean's contribution.
  return ss - s * s / x.size();
}

double mean(const std::vector<double>& x) {
  return static_cast<double>(mean_ld(x));
}

double variance(const std::vector<double>& x) {
  if (x.size() < 2) return std::numeric_limits<double>::quiet_NaN();
  return static_cast<double>(sum_sq_dev(x) / (x.size() - 1));
}

double sd(const std::vector<double>& x) {
  return std::sqrt(variance(x));
}

double quantile(std::vector<double> x, double p) {
  if (x.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(x.begin(), x.end());
  double h = (x.size() - 1) * p;
  size_t lo = static_cast<size_t>(std::floor(h));
  if (lo + 1 >= x.size()) return x.back();
  return x[lo] + (h - lo) * (x[lo + 1] - x[lo]);
}

double median(std::vector<double> x) {
  return quantile(std::move(x), 0.5);
}

Descriptives describe(const std::vector<double>& x, double offset, double ci_level) {
  Descriptives d;
  d.n = static_cast<int>(x.size());
  d.ci_level = ci_level;
  if (x.empty()) return d;
  std::vector<double> s = x;
  std::sort(s.begin(), s.end());
  long double m = mean_ld(x);
  d.mean = static_cast<double>(m + offset);
  d.sd = sd(x);
  d.se = d.sd / std::sqrt(static_cast<double>(d.n));
  d.median = quantile(s, 0.5) + offset;
  d.q1 = quantile(s, 0.25) + offset;
  d.q3 = quantile(s, 0.75) + offset;
  d.iqr = quantile(s, 0.75) - quantile(s, 0.25);
  d.min = s.front() + offset;
  d.max = s.back() + offset;
  if (d.n >= 2) {
    double t = t_quantile(0.5 + ci_level / 2, d.n - 1);
    d.ci_low = static_cast<double>(m - t * d.se + offset);
    d.ci_high = static_cast<double>(m + t * d.se + offset);
  } else {
    d.ci_low = d.ci_high = std::numeric_limits<double>::quiet_NaN();
  }
  return d;
}

ProportionInterval wilson_interval(int k, int n, double level) {
  ProportionInterval r;
  if (n <= 0 || k < 0 || k > n) return {NAN, NAN, NAN};
  const double z = gsl_cdf_ugaussian_Qinv(0.5 * (1 - level));
  const double p = static_cast<double>(k) / n, z2n = z * z / n;
  const double centre = (p + 0.5 * z2n) / (1 + z2n);
  const double half = z / (1 + z2n) * std::sqrt(p * (1 - p) / n + 0.25 * z2n / n);
  r.p = p;
  // Clamp only the rounding: the exact bounds are 0 for k = 0 and 1 for k = n.
  r.low = k == 0 ? 0.0 : std::max(0.0, centre - half);
  r.high = k == n ? 1.0 : std::min(1.0, centre + half);
  return r;
}

}  // namespace palplab::analysis
