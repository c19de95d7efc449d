#include "analysis/two_sample.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "analysis/anova.hpp"
#include "analysis/descriptives.hpp"
#include "analysis/distributions.hpp"
#include "common/nan.hpp"

namespace palplab::analysis {

namespace {

void need_two(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() < 2 || b.size() < 2)
    throw std::invalid_argument("two-sample test: each sample needs >= 2 values");
}

void finish(TTest& r) {
  if (!(r.se > 0)) {
    r.defined = false;
    r.t = r.p = r.ci_low = r.ci_high = kNaN;
    return;
  }
  // t may be huge (1.7e200: a constant group beside a tightly spread one), even inf (an SE
  // of subnormal size): its p is then the bound, never NaN.
  r.t = r.mean_diff / r.se;
  r.p = t_two_sided_p_wide(r.t, r.df);
  double q = t_quantile(0.975, r.df);
  r.ci_low = r.mean_diff - q * r.se;
  r.ci_high = r.mean_diff + q * r.se;
}
// Beyond |t| = 1e150 (t² > 1e300) the series term below is used: there x = df/t² < 1e-290·df,
// so the neglected terms (relative O(x)) are far below double precision.
constexpr double kWideT = 1e150;

// log B(a, b) in long double.
long double log_beta(long double a, long double b) {
  return std::lgamma(a) + std::lgamma(b) - std::lgamma(a + b);
}

// log of x^a / (a B(a, b)): the leading term of the regularized incomplete beta function
// I_x(a, b) = x^a (1 - x)^b / (a B(a, b)) · (1 + O(x)) as x -> 0.
long double log_beta_inc_leading(long double log_x, long double a, long double b) {
  return a * log_x - std::log(a) - log_beta(a, b);
}
}  // namespace

TTest student_t(const std::vector<double>& a, const std::vector<double>& b) {
  need_two(a, b);
  TTest r;
  const double na = a.size(), nb = b.size();
  r.mean_diff = static_cast<double>(mean_ld(a) - mean_ld(b));
  r.df = r.df_exact = na + nb - 2;
  long double sp2 = (sum_sq_dev(a) + sum_sq_dev(b)) / (na + nb - 2);
  r.se = static_cast<double>(std::sqrt(sp2 * (1 / na + 1 / nb)));
  finish(r);
  return r;
}

TTest welch_t_moments(const std::vector<double>& a, const std::vector<double>& b, DfMode mode) {
  need_two(a, b);
  TTest r;
  r.welch = true;
  const double na = a.size(), nb = b.size();
  r.mean_diff = static_cast<double>(mean_ld(a) - mean_ld(b));
  long double va = sum_sq_dev(a) / (na - 1) / na, vb = sum_sq_dev(b) / (nb - 1) / nb;
  r.se = static_cast<double>(std::sqrt(va + vb));
  long double den = va * va / (na - 1) + vb * vb / (nb - 1);
  r.df_exact = den > 0 ? static_cast<double>((va + vb) * (va + vb) / den) : kNaN;
  r.df = mode == DfMode::Floor ? std::max(1.0, std::floor(r.df_exact)) : r.df_exact;
  return r;
}

TTest welch_t(const std::vector<double>& a, const std::vector<double>& b, DfMode mode) {
  TTest r = welch_t_moments(a, b, mode);
  finish(r);
  return r;
}

namespace {
// Number of arrangements with U = u for sample sizes (m, n), u = 0..m·n, by the recurrence
// c(m, n, u) = c(m-1, n, u-n) + c(m, n-1, u) (additions only: no cancellation).
std::vector<long double> mann_whitney_counts(int m, int n) {
  // table[j] = counts for (i, j) while sweeping i.
  std::vector<std::vector<long double>> prev(n + 1), cur(n + 1);
  for (int j = 0; j <= n; ++j) prev[j] = {1.0L};  // i = 0: U = 0 only
  for (int i = 1; i <= m; ++i) {
    cur[0] = {1.0L};  // j = 0: U = 0 only
    for (int j = 1; j <= n; ++j) {
      std::vector<long double> c(static_cast<size_t>(i) * j + 1, 0.0L);
      // The largest of the i+j values belongs to sample 1 (adds j to U) or to sample 2.
      for (size_t u = 0; u < prev[j].size(); ++u) c[u + j] += prev[j][u];
      for (size_t u = 0; u < cur[j - 1].size(); ++u) c[u] += cur[j - 1][u];
      cur[j] = std::move(c);
    }
    std::swap(prev, cur);
  }
  return prev[n];
}
}  // namespace

MannWhitney mann_whitney(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> sa = a, sb = b;
  std::stable_sort(sa.begin(), sa.end());  // stable_sort: no out-of-range reads on a NaN
  std::stable_sort(sb.begin(), sb.end());
  return mann_whitney_sorted(sa, sb);
}

MannWhitney mann_whitney_sorted(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.empty() || b.empty()) throw std::invalid_argument("Mann-Whitney: empty sample");
  // Mid-ranks of the pooled sample by merging the two sorted samples: each run of equal values
  // (from either sample) gets the average of its ranks. Ranks are multiples of 1/2 and their
  // sum is exact in long double, so the order of summation does not matter; the tie sum is
  // accumulated in increasing order of value, as midranks() does.
  double ties = 0;
  long double rs = 0;
  for (size_t i = 0, j = 0; i < a.size() || j < b.size();) {
    const bool from_a = j == b.size() || (i < a.size() && a[i] < b[j]);
    const double v = from_a ? a[i] : b[j];
    size_t ia = i, jb = j;
    while (ia < a.size() && a[ia] == v) ++ia;
    while (jb < b.size() && b[jb] == v) ++jb;
    if (ia == i && jb == j) (from_a ? ia : jb) += 1;            // a NaN: a run of its own, no loop
    const size_t run = (ia - i) + (jb - j), first = i + j + 1;  // 1-based rank of the run start
    const double rank = 0.5 * (static_cast<double>(first) + static_cast<double>(first + run - 1));
    for (size_t t = i; t < ia; ++t) rs += rank;
    const double t = static_cast<double>(run);
    ties += t * t * t - t;
    i = ia;
    j = jb;
  }
  const double na = a.size(), nb = b.size(), n = na + nb;
  MannWhitney mw;
  mw.W = static_cast<double>(rs - na * (na + 1) / 2);
  mw.exact = na < 50 && nb < 50 && ties == 0;
  if (mw.exact) {
    auto c = mann_whitney_counts(static_cast<int>(na), static_cast<int>(nb));
    long double total = 0;
    for (auto v : c) total += v;
    // R: p = 2·P(W >= w) if w > na·nb/2 else 2·P(W <= w), capped at 1.
    int w = static_cast<int>(std::lround(mw.W));
    long double tail = 0;
    if (mw.W > na * nb / 2) {
      for (size_t u = w; u < c.size(); ++u) tail += c[u];
    } else {
      for (int u = 0; u <= w; ++u) tail += c[u];
    }
    mw.p = clamp_p(static_cast<double>(std::min<long double>(1, 2 * tail / total)));
    return mw;
  }
  double z = mw.W - na * nb / 2;
  double sigma = std::sqrt(na * nb / 12 * ((n + 1) - ties / (n * (n - 1))));
  if (!(sigma > 0)) {
    mw.defined = false;
    mw.z = mw.p = kNaN;
    return mw;
  }
  double correction = z > 0 ? 0.5 : (z < 0 ? -0.5 : 0);
  mw.z = (z - correction) / sigma;
  mw.p = normal_two_sided_p(mw.z);
  return mw;
}

// d and g of cohens_d, without an interval (cohens_d_welch replaces the pooled one).
EffectSize cohens_d_point(const std::vector<double>& a, const std::vector<double>& b,
                          double level) {
  need_two(a, b);
  EffectSize e;
  e.level = level;
  const double na = a.size(), nb = b.size(), nu = na + nb - 2;
  long double sp = std::sqrt((sum_sq_dev(a) + sum_sq_dev(b)) / nu);
  if (!(sp > 0)) {
    e.defined = false;
    e.d = e.g = e.d_ci_low = e.d_ci_high = e.g_ci_low = e.g_ci_high = kNaN;
    return e;
  }
  e.d = static_cast<double>((mean_ld(a) - mean_ld(b)) / sp);
  const double j = std::exp(std::lgamma(nu / 2) - std::lgamma((nu - 1) / 2)) / std::sqrt(nu / 2);
  e.g = j * e.d;
  return e;
}

EffectSize cohens_d(const std::vector<double>& a, const std::vector<double>& b, double level) {
  EffectSize e = cohens_d_point(a, b, level);
  if (!e.defined) return e;
  const double na = a.size(), nb = b.size(), nu = na + nb - 2;
  const double j = std::exp(std::lgamma(nu / 2) - std::lgamma((nu - 1) / 2)) / std::sqrt(nu / 2);
  // d·/sqrt(1/na + 1/nb) is Student's t, noncentral t(ν, δ) with δ = true d/sqrt(1/na+1/nb):
  // the interval for δ inverts its CDF at the observed t.
  const double scale = std::sqrt(1 / na + 1 / nb);
  const double t = e.d / scale;
  const double alpha = 1 - level;
  e.d_ci_low = noncentral_t_delta_for_cdf(t, nu, 1 - alpha / 2) * scale;
  e.d_ci_high = noncentral_t_delta_for_cdf(t, nu, alpha / 2) * scale;
  e.g_ci_low = j * e.d_ci_low;
  e.g_ci_high = j * e.d_ci_high;
  return e;
}

EffectSize cohens_d_welch(const std::vector<double>& a, const std::vector<double>& b,
                          const TTest& w, double level) {
  // The pooled interval of cohens_d is not computed: it would be replaced below (two root
  // searches on the noncentral t per pair saved).
  EffectSize e = cohens_d_point(a, b, level);
  e.ci_method = "welch";
  if (!e.defined || !w.defined) {
    e.d_ci_low = e.d_ci_high = e.g_ci_low = e.g_ci_high = kNaN;
    return e;
  }
  // Welch's t = Δ̂/SE_w is noncentral t(ν_w, δ = Δ/SE_w) (approximately, as the test itself
  // assumes); invert it at the observed t and convert δ to the d scale by SE_w / s_pooled.
  // At δ = 0 the inverted CDF is the test's own null distribution, hence the consistency.
  const double na = a.size(), nb = b.size(), nu = na + nb - 2;
  const double sp = static_cast<double>(std::sqrt((sum_sq_dev(a) + sum_sq_dev(b)) / nu));
  const double scale = w.se / sp, alpha = 1 - level;
  e.d_ci_low = noncentral_t_delta_for_cdf(w.t, w.df, 1 - alpha / 2) * scale;
  e.d_ci_high = noncentral_t_delta_for_cdf(w.t, w.df, alpha / 2) * scale;
  const double j = e.g / e.d;
  e.g_ci_low = j * e.d_ci_low;
  e.g_ci_high = j * e.d_ci_high;
  return e;
}

double t_two_sided_p_wide(double t, double df) {
  if (std::isnan(t) || !(df > 0)) return kNaN;
  const double at = std::fabs(t);
  if (at <= kWideT) return t_two_sided_p(t, df);
  // Normal limit (the F path's own switch): a tail of exp(-t²/2) with |t| > 1e150.
  if (df > 1e9) return kPFloor;
  // P(|T| > |t|) = I_x(df/2, 1/2), x = df / (df + t²) = df / t² to relative 1e-290.
  const long double log_x =
      std::log(static_cast<long double>(df)) - 2 * std::log(static_cast<long double>(at));
  const long double log_p = log_beta_inc_leading(log_x, 0.5L * df, 0.5L);
  return clamp_p(static_cast<double>(std::exp(log_p)));
}

double t_upper_p(double t, double df) {
  const double two = t_two_sided_p_wide(t, df);
  if (std::isnan(two)) return kNaN;
  // Below the floor the two-sided p is a bound, and so is its half.
  if (t > 0) return p_is_bound(two) ? kPFloor : clamp_p(two / 2);
  return clamp_p(1 - two / 2);
}

double f_upper_p_log(double log_f, double d1, double d2) {
  if (std::isnan(log_f) || !(d1 > 0) || !(d2 > 0)) return kNaN;
  if (log_f < std::log(1e300)) return f_upper_p(std::exp(log_f), d1, d2);
  if (d2 > 1e9) return kPFloor;  // χ²_d1 limit: a tail of exp(-d1·F/2), F > 1e300
  // P(F > f) = I_x(d2/2, d1/2), x = d2 / (d2 + d1 f) = d2 / (d1 f) to relative 1e-290.
  const long double log_x = std::log(static_cast<long double>(d2)) -
                            std::log(static_cast<long double>(d1)) -
                            static_cast<long double>(log_f);
  const long double log_p = log_beta_inc_leading(log_x, 0.5L * d2, 0.5L * d1);
  return clamp_p(static_cast<double>(std::exp(log_p)));
}

Equivalence tost_welch(const std::vector<double>& a, const std::vector<double>& b, double low,
                       double high, double alpha, DfMode mode) {
  if (!(low < high)) throw std::invalid_argument("TOST: the lower margin must be below the upper");
  if (!(alpha > 0 && alpha < 0.5)) throw std::invalid_argument("TOST: alpha must be in (0, 0.5)");
  TTest w = welch_t(a, b, mode);
  Equivalence e;
  e.low = low;
  e.high = high;
  e.alpha = alpha;
  e.df = w.df;
  e.se = w.se;
  e.mean_diff = w.mean_diff;
  e.p_difference = w.p;
  if (!w.defined) {
    e.defined = false;
    e.t_low = e.t_high = e.p_low = e.p_high = e.p = e.ci_low = e.ci_high = kNaN;
    e.verdict = "undefined";
    return e;
  }
  // One-sided tails from the two-sided p (which keeps its relative accuracy far out), for any
  // t: a margin of 1e160 gives t ~ 1e160, whose square overflows (p was NaN, the verdict
  // "different"); a tail below 1e-300 is the bound (it was 5e-301, below the floor).
  e.t_low = (w.mean_diff - low) / w.se;
  e.t_high = (w.mean_diff - high) / w.se;
  e.p_low = t_upper_p(e.t_low, w.df);
  e.p_high = t_upper_p(-e.t_high, w.df);
  e.p = std::max(e.p_low, e.p_high);
  const double q = t_quantile(1 - alpha, w.df);
  e.ci_low = w.mean_diff - q * w.se;
  e.ci_high = w.mean_diff + q * w.se;
  e.verdict = e.p < alpha ? "equivalent" : (w.p < alpha ? "different" : "inconclusive");
  return e;
}

}  // namespace palplab::analysis
