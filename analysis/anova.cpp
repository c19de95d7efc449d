#include "analysis/anova.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "analysis/descriptives.hpp"
#include "analysis/distributions.hpp"
#include "analysis/two_sample.hpp"
#include "common/nan.hpp"

namespace palplab::analysis {

namespace {}

Anova oneway_anova(const Groups& groups) {
  const size_t k = groups.size();
  if (k < 2) throw std::invalid_argument("ANOVA needs at least 2 groups");
  size_t n_total = 0;
  long double sum = 0;
  std::vector<long double> means(k);
  for (size_t g = 0; g < k; ++g) {
    if (groups[g].empty()) throw std::invalid_argument("ANOVA: empty group");
    means[g] = mean_ld(groups[g]);
    n_total += groups[g].size();
    sum += means[g] * groups[g].size();
  }
  if (n_total <= k) throw std::invalid_argument("ANOVA needs more values than groups");
  long double grand = sum / n_total;
  long double ssb = 0, ssw = 0;
  for (size_t g = 0; g < k; ++g) {
    long double d = means[g] - grand;
    ssb += groups[g].size() * d * d;
    ssw += sum_sq_dev(groups[g]);
  }
  Anova a;
  a.df_between = static_cast<double>(k - 1);
  a.df_within = static_cast<double>(n_total - k);
  a.ss_between = static_cast<double>(ssb);
  a.ss_within = static_cast<double>(ssw);
  long double msb = ssb / (k - 1), msw = ssw / (n_total - k);
  a.ms_between = static_cast<double>(msb);
  a.ms_within = static_cast<double>(msw);
  a.residual_sd = static_cast<double>(std::sqrt(msw));
  long double sst = ssb + ssw;
  a.eta_squared = sst > 0 ? static_cast<double>(ssb / sst) : kNaN;
  a.omega_squared = sst > 0 ? static_cast<double>((ssb - (k - 1) * msw) / (sst + msw)) : kNaN;
  // Only exactly no within-group variation is undefined: the values are read exactly
  // (decimal.hpp), so identical values give ssw = 0 exactly, and a tiny but real spread (F =
  // 1.5e18) is a valid, if extreme, F.
  const bool no_within = !(ssw > 0);
  if (!no_within) {
    a.F = static_cast<double>(msb / msw);
    a.p = f_upper_p(a.F, a.df_between, a.df_within);
    // F beyond a double (msw may be far below a double's range, its long double is not): p
    // from log F, which long double holds.
    if (std::isinf(a.F) && msb > 0) {
      const long double log_f = std::log(msb) - std::log(msw);
      a.p = f_upper_p_log(static_cast<double>(log_f), a.df_between, a.df_within);
      a.log10_F = static_cast<double>(log_f / std::log(10.0L));
    }
  } else {
    a.defined = false;
    a.F = msb > 0 ? std::numeric_limits<double>::infinity() : kNaN;
    a.p = kNaN;
  }
  return a;
}

WelchAnova welch_anova(const Groups& groups) {
  const size_t k = groups.size();
  if (k < 2) throw std::invalid_argument("Welch ANOVA needs at least 2 groups");
  WelchAnova r;
  r.df_between = static_cast<double>(k - 1);
  std::vector<long double> w(k), m(k);
  long double wsum = 0;
  for (size_t g = 0; g < k; ++g) {
    if (groups[g].size() < 2) throw std::invalid_argument("Welch ANOVA: a group with < 2 values");
    long double var = sum_sq_dev(groups[g]) / (groups[g].size() - 1);
    if (!(var > 0)) {
      r.defined = false;
      r.F = r.p = r.df_within = r.eta_squared = kNaN;
      return r;
    }
    w[g] = groups[g].size() / var;
    m[g] = mean_ld(groups[g]);
    wsum += w[g];
  }
  long double mw = 0;
  for (size_t g = 0; g < k; ++g) mw += w[g] * m[g];
  mw /= wsum;
  long double a = 0, tmp = 0;
  for (size_t g = 0; g < k; ++g) {
    long double d = m[g] - mw;
    a += w[g] * d * d;
    long double f = 1 - w[g] / wsum;
    tmp += f * f / (groups[g].size() - 1);
  }
  long double kk = static_cast<long double>(k);
  a /= (kk - 1);
  tmp /= (kk * kk - 1);  // R's oneway.test: tmp = Σ(1 - w/W)²/(n - 1) / (k² - 1)
  long double F = a / (1 + 2 * (kk - 2) * tmp);
  r.F = static_cast<double>(F);
  r.df_within = static_cast<double>(1 / (3 * tmp));
  r.p = f_upper_p(r.F, r.df_between, r.df_within);
  r.eta_squared = r.F * r.df_between / (r.F * r.df_between + r.df_within);
  return r;
}

Anova levene(const Groups& groups, LeveneCentre centre) {
  Groups dev(groups.size());
  for (size_t g = 0; g < groups.size(); ++g) {
    // Centre and deviations in long double, so that deviations equal in exact arithmetic
    // (both of a group of two) come out equal and "no variation" stays exactly zero.
    long double c = mean_ld(groups[g]);
    if (centre == LeveneCentre::Median) {
      std::vector<double> s = groups[g];
      std::sort(s.begin(), s.end());
      const size_t n = s.size();
      c = n % 2 ? s[n / 2] : (static_cast<long double>(s[n / 2 - 1]) + s[n / 2]) / 2;
    }
    for (double v : groups[g]) dev[g].push_back(static_cast<double>(std::fabs(v - c)));
  }
  return oneway_anova(dev);
}

std::vector<double> midranks(const std::vector<double>& x, double* tie_sum) {
  const size_t n = x.size();
  // (value, index) pairs sorted by value, contiguous (no indirection through x): ranks depend
  // only on the values (equal values share their mean rank), not on the order within ties.
  std::vector<std::pair<double, size_t>> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = {x[i], i};
  std::stable_sort(v.begin(), v.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<double> r(n);
  double ts = 0;
  for (size_t i = 0; i < n;) {
    size_t j = i;
    while (j + 1 < n && v[j + 1].first == v[i].first) ++j;
    double rank = 0.5 * (static_cast<double>(i + 1) + static_cast<double>(j + 1));
    for (size_t t = i; t <= j; ++t) r[v[t].second] = rank;
    double t = static_cast<double>(j - i + 1);
    ts += t * t * t - t;
    i = j + 1;
  }
  if (tie_sum) *tie_sum = ts;
  return r;
}

KruskalWallis kruskal_wallis(const Groups& groups) {
  const size_t k = groups.size();
  if (k < 2) throw std::invalid_argument("Kruskal-Wallis needs at least 2 groups");
  std::vector<double> all;
  for (auto& g : groups) all.insert(all.end(), g.begin(), g.end());
  double ties = 0;
  std::vector<double> r = midranks(all, &ties);
  const double n = static_cast<double>(all.size());
  long double stat = 0;
  size_t off = 0;
  for (auto& g : groups) {
    long double rs = 0;
    for (size_t i = 0; i < g.size(); ++i) rs += r[off + i];
    off += g.size();
    stat += rs * rs / g.size();
  }
  KruskalWallis kw;
  kw.df = static_cast<double>(k - 1);
  kw.tie_correction = 1 - ties / (n * n * n - n);
  if (!(kw.tie_correction > 0)) {
    kw.defined = false;
    kw.H = kw.p = kNaN;
    return kw;
  }
  long double h = 12.0L / (n * (n + 1)) * stat - 3 * (n + 1);
  kw.H = static_cast<double>(h / kw.tie_correction);
  kw.p = chi2_upper_p(kw.H, kw.df);
  return kw;
}

}  // namespace palplab::analysis
