#include "analysis/distributions.hpp"

#include <gsl/gsl_cdf.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_randist.h>
#include <gsl/gsl_sf_gamma.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>

#include "analysis/quadrature.hpp"

namespace palplab::analysis {

using ld = long double;

void gsl_quiet() {
  static std::once_flag once;
  std::call_once(once, [] { gsl_set_error_handler_off(); });
}

// t_two_sided_p and f_upper_p are defined after the quadrature helpers below.

double chi2_upper_p(double x, double df) {
  gsl_quiet();
  if (!std::isfinite(x) || !(df > 0)) return std::numeric_limits<double>::quiet_NaN();
  if (x <= 0) return 1.0;
  return clamp_p(gsl_cdf_chisq_Q(x, df));
}

double normal_two_sided_p(double z) {
  gsl_quiet();
  if (!std::isfinite(z)) return std::numeric_limits<double>::quiet_NaN();
  return clamp_p(2 * gsl_cdf_ugaussian_Q(std::fabs(z)));
}

double t_quantile(double p, double df) {
  gsl_quiet();
  if (!(p > 0 && p < 1) || !(df > 0)) return std::numeric_limits<double>::quiet_NaN();
  if (p == 0.5) return 0;
  // P(|T| > t) = P(F(1, df) > t²) = 2 min(p, 1-p).
  double tail = 2 * std::min(p, 1 - p);
  double t = std::sqrt(gsl_cdf_fdist_Qinv(tail, 1.0, df));
  if (!std::isfinite(t)) {
    // GSL's F quantile fails for some large df (tail .05, df 4000 gives NaN); the t quantile
    // does not, and Newton steps on our own accurate two-sided p restore the last digits.
    t = gsl_cdf_tdist_Qinv(tail / 2, df);
    for (int it = 0; it < 3 && std::isfinite(t) && t > 0; ++it) {
      const double dens = gsl_ran_tdist_pdf(t, df);
      if (!(dens > 0)) break;
      t += (t_two_sided_p(t, df) - tail) / (2 * dens);
    }
  }
  return p > 0.5 ? t : -t;
}

namespace {

// Tolerances on |halves - whole| of the adaptive rule; the accepted halves are far more
// accurate than this difference for these analytic integrands (checked against mpmath).
constexpr ld kInnerTol = 1e-10L, kOuterTol = 1e-10L;
constexpr ld kSqrt2 = 1.414213562373095048801688724209698079L;
constexpr double kSqrt2d = 1.4142135623730951;

// The inner integrand of the range distribution runs ~10^5 times per CDF value: it is
// evaluated in double (relative error ~1e-15, well inside the 1e-11 target) and summed in
// long double.
double phi_d(double x) {
  return 0.3989422804014327 * std::exp(-0.5 * x * x);
}
double upper_normal_d(double x) {
  return 0.5 * std::erfc(x * 0.7071067811865476);
}
double log_phi_d(double x) {
  return -0.5 * x * x - 0.91893853320467274;
}
// log Q(x) without underflow: erfc where Q(x) > 1e-198, else the asymptotic series
// Q(x) = φ(x)/x · (1 - u + 3u² - 15u³ + 105u⁴ - 945u⁵ + 10395u⁶ - ...), u = 1/x², whose next
// term at x = 30 is 3e-16 relative.
double log_upper_normal_d(double x) {
  if (x < 30) return std::log(upper_normal_d(x));
  const double u = 1 / (x * x);
  const double series =
      1 - u * (1 - 3 * u * (1 - 5 * u * (1 - 7 * u * (1 - 9 * u * (1 - 11 * u)))));
  return log_phi_d(x) - std::log(x) + std::log(series);
}
// Widths of the range beyond which its upper tail is integrated in log space (range_prob).
constexpr double kLogSpaceRange = 24;
// Φ(a + w) - Φ(a) for w >= 0 without cancellation: a short interval by Gauss–Legendre on the
// density (with the half-width w/2 taken exactly, not as a difference of rounded end points,
// whose relative error ~eps·|a|/w would make the integrand jitter for tiny w), otherwise the
// difference of the two tails on the same side of 0, or erf sums when it straddles 0.
double normal_mass_d(double a, double w) {
  if (w <= 0.0625) {  // 8 nodes integrate φ over so short an interval to full precision
    static const GaussLegendre<8> g;
    static const auto xw = [] {
      std::array<double, 16> r{};
      for (int i = 0; i < 8; ++i) {
        r[i] = static_cast<double>(g.x[i]);
        r[8 + i] = static_cast<double>(g.w[i]);
      }
      return r;
    }();
    double h = 0.5 * w, c = a + h, s = 0;
    for (int i = 0; i < 8; ++i) s += xw[8 + i] * phi_d(c + h * xw[i]);
    return s * h;
  }
  const double b = a + w;
  if (a >= 0) return upper_normal_d(a) - upper_normal_d(b);
  if (b <= 0) return upper_normal_d(-b) - upper_normal_d(-a);
  return 0.5 * (std::erf(b * 0.7071067811865476) + std::erf(-a * 0.7071067811865476));
}

// log density of S = sqrt(χ²_ν/ν) at s > 0.
struct ChiScaled {
  ld nu, log_norm;
  explicit ChiScaled(ld nu_) : nu(nu_) {
    log_norm = std::log(2.0L) + 0.5L * nu * std::log(0.5L * nu) - std::lgamma(0.5L * nu);
  }
  ld density(ld s) const {
    if (s <= 0) return 0;
    return std::exp(log_density(s));
  }
  ld log_density(ld s) const {
    return s > 0 ? log_norm + (nu - 1) * std::log(s) - 0.5L * nu * s * s : -INFINITY;
  }
  // s beyond which the density is below e^-250 (nothing we report is that small relative to
  // the mass near the mode).
  ld upper_limit() const {
    ld s = std::max<ld>(2, std::sqrt(std::max<ld>(nu - 1, 1) / nu));
    while (log_norm + (nu - 1) * std::log(s) - 0.5L * nu * s * s > -250) s *= 1.25L;
    return s;
  }
};

// Breakpoints of an integral over s ∈ [0, smax] against the density of S: around each centre c
// at c(1 ± d·width), d = 0, 3, 8, 20 (so no piece hides a Gaussian-like peak or tail
// at its edge, where every node of the rule would see zero), and for ν < 2, where the density
// s^(ν-1) is singular or not smooth at 0, a geometric grading towards 0.
std::vector<ld> outer_breakpoints(ld nu, std::initializer_list<ld> centres, ld width, ld smax) {
  std::vector<ld> pts{0, smax};
  ld lowest = smax;
  for (ld c : centres)
    for (ld d : {0.0L, 3.0L, 8.0L, 20.0L})
      for (ld sign : {-1.0L, 1.0L}) {
        ld p = c * (1 + sign * d * width);
        if (p > 0 && p < smax) {
          pts.push_back(p);
          lowest = std::min(lowest, p);
        }
      }
  if (nu < 2)
    for (int j = 1; j <= 30; ++j) pts.push_back(lowest * std::ldexp(1.0L, -j));
  return pts;
}

// P(R <= w) (lower) or P(R > w) (upper) for the range R of k standard normals.
ld range_prob(ld w, int k, bool upper) {
  if (w <= 0) return upper ? 1.0L : 0.0L;
  const int m = k - 1;
  const double wd = static_cast<double>(w);
  auto lower_f = [&](ld zl) {
    double z = static_cast<double>(zl);
    double b = normal_mass_d(z, wd);
    return static_cast<ld>(k * phi_d(z) * std::pow(b, m));
  };
  // 1 - P(R <= w) = k ∫ φ(z) [Q(z)^m - (Q(z) - Q(z+w))^m] dz, the bracket written as
  // Q(z)^m (1 - (1 - r)^m) with r = Q(z+w)/Q(z): no cancellation when it is tiny.
  auto upper_f = [&](ld zl) {
    double z = static_cast<double>(zl);
    double a = upper_normal_d(z);
    if (a <= 0) return 0.0L;
    double r = upper_normal_d(z + wd) / a;
    if (r >= 1) r = 1;
    double frac = -std::expm1(m * std::log1p(-r));
    return static_cast<ld>(k * phi_d(z) * std::pow(a, m) * frac);
  };
  // The lower-tail integrand lives in z ∈ [-12, 12] (φ(z) and a bracket <= 1); the upper
  // one also near z = -w/2 (φ(z)·Q(z+w) peaks there for a wide range). Breakpoints at the
  // peaks keep the adaptive rule from stepping over a narrow peak inside a long piece.
  std::vector<ld> pts{-12, -3, 0, 3, 12};
  const ld c = -0.5L * w;
  if (c > -12) pts.push_back(c);
  if (upper)
    for (ld d : {-12.0L, -3.0L, 0.0L, 3.0L, 12.0L}) pts.push_back(c + d);
  if (upper && w > kLogSpaceRange) {
    // Far tail: the integrand (~φ(w/2)², below 1e-100) would underflow a double at its
    // shoulders, and with it the rule's error estimate (the cause of the old budget burn).
    // Evaluate it in log space, scaled by its value at the peak z = -w/2, and put the scale
    // back in long double (whose range reaches 1e-4900).
    const double m_d = m, log_k = std::log(static_cast<double>(k)), log_m = std::log(m_d);
    auto log_f = [&](double z) {
      double la = log_upper_normal_d(z), lr = log_upper_normal_d(z + wd) - la;  // log r <= 0
      double lfrac = lr < -30 ? log_m + lr + std::log1p(-0.5 * (m_d - 1) * std::exp(lr))
                              : std::log(-std::expm1(m_d * std::log1p(-std::exp(lr))));
      return log_k + log_phi_d(z) + m_d * la + lfrac;
    };
    const double scale = log_f(static_cast<double>(c));
    auto scaled = [&](ld z) {
      return static_cast<ld>(std::exp(log_f(static_cast<double>(z)) - scale));
    };
    return integrate(scaled, pts, kInnerTol) * std::exp(static_cast<ld>(scale));
  }
  ld v = upper ? integrate(upper_f, pts, kInnerTol) : integrate(lower_f, pts, kInnerTol);
  return std::clamp<ld>(v, 0, 1);
}

// log P(R > w) of the range of k standard normals for w in [0, kTableMax], tabulated once per
// k: piecewise Chebyshev interpolation (kTableDeg + 1 nodes of the second kind per unit
// interval, barycentric form) of the log of range_prob. A p-value integrates P(R > q s) over s
// at ~10^3 nodes, so one table (~1700 range_prob calls, a few ms) replaces the inner integral
// of every later p-value with the same k: Tukey and Games–Howell over 435 pairs went from
// ~60 s to well under a second. The table checks itself on construction at points between
// nodes and is not used (nullptr) if any is off by more than 1e-13 relative.
constexpr int kTableDeg = 20;
constexpr double kTableMax = 80;  // P(R > 80) < 1e-690: beyond, range_prob directly
class RangeUpperTable {
 public:
  explicit RangeUpperTable(int k) {
    const int pieces = static_cast<int>(kTableMax);
    nodes_.resize(kTableDeg + 1);
    for (int i = 0; i <= kTableDeg; ++i) nodes_[i] = 0.5 - 0.5 * std::cos(M_PI * i / kTableDeg);
    logp_.resize(static_cast<size_t>(pieces) * (kTableDeg + 1));
    for (int j = 0; j < pieces; ++j)
      for (int i = 0; i <= kTableDeg; ++i)
        logp_[j * (kTableDeg + 1) + i] =
            static_cast<double>(std::log(range_prob(j + nodes_[i], k, true)));
    ok_ = true;
    for (double w : {0.137, 1.61, 3.3, 5.92, 9.47, 17.5, 26.3, 41.7, 63.1, 79.4}) {
      const double direct = static_cast<double>(std::log(range_prob(w, k, true)));
      // |Δ log P| is the relative error of P.
      if (!(std::fabs(log_upper(w) - direct) <= 1e-13 * std::max(1.0, std::fabs(direct)) + 1e-14))
        ok_ = false;
    }
  }
  bool ok() const { return ok_; }
  double log_upper(double w) const {
    int j = std::min(static_cast<int>(w), static_cast<int>(kTableMax) - 1);
    const double x = w - j;
    const double* v = &logp_[static_cast<size_t>(j) * (kTableDeg + 1)];
    double num = 0, den = 0;
    for (int i = 0; i <= kTableDeg; ++i) {
      const double d = x - nodes_[i];
      if (d == 0) return v[i];
      const double c = (i % 2 ? -1.0 : 1.0) * (i == 0 || i == kTableDeg ? 0.5 : 1.0) / d;
      num += c * v[i];
      den += c;
    }
    return num / den;
  }
  static const RangeUpperTable* get(int k) {
    static std::mutex m;
    static std::map<int, std::unique_ptr<RangeUpperTable>> tables;
    std::lock_guard<std::mutex> lock(m);
    auto& t = tables[k];
    if (!t) t = std::make_unique<RangeUpperTable>(k);
    return t->ok() ? t.get() : nullptr;
  }

 private:
  std::vector<double> nodes_, logp_;
  bool ok_ = false;
};

// log P(|T_ν| > t) <= this (t > 0): with x = ν/(ν + t²), P(|T| > t) = I_x(ν/2, 1/2)
// = x^a (1-x)^b / (a B(a,b)) · 2F1(a+b, 1; a+1; x), and for b = 1/2 every coefficient of the
// 2F1 series is <= 1, so the series is <= 1/(1 - x). ν = ∞: P(|Z| > t) <= 2φ(t)/t.
ld log_t_two_sided_bound(ld t, ld nu) {
  if (std::isinf(nu))
    return std::log(2.0L) - 0.5L * t * t - 0.918938533204672741780329736L - std::log(t);
  const ld a = 0.5L * nu, b = 0.5L, t2 = t * t;
  const ld log_x = std::log(nu) - std::log(nu + t2), log_1mx = std::log(t2) - std::log(nu + t2);
  const ld lbeta = std::lgamma(a) + std::lgamma(b) - std::lgamma(a + b);
  return a * log_x + (b - 1) * log_1mx - std::log(a) - lbeta;
}

// Above this q the upper tail is integrated in t = q·s (studentized_range_far_upper).
constexpr double kFarQ = 1e8;

// P(Q > q) far in the tail: the mass of ∫ f_S(s) P(R > qs) ds lies at s ~ 1/q, below any grid
// of [0, smax] (q = 1e11 gave 0 or NaN: Tukey's p of groups 1e-11 apart fell to the 1e-300
// floor while the ANOVA's was 2.7e-44, review 2026-12-07). With t = q·s, exactly,
// P(Q > q) = c q^-ν ∫ t^(ν-1) e^(-ν t²/(2q²)) P(R > t) dt, c the density's constant
// (ChiScaled::log_norm), an integrand of scale 1 peaking near t* below; summed relative to its
// log at t* (ν up to 1e7 would overflow t^(ν-1)).
ld studentized_range_far_upper(double q, int k, double df) {
  const ChiScaled chi(df);
  const ld nu = df, qq = q;
  const ld tstar = std::sqrt(std::max<ld>(nu - 1, 0.5L) / (nu / (qq * qq) + 0.5L));
  const RangeUpperTable* table = RangeUpperTable::get(k);
  auto log_g = [&](ld t) -> ld {
    const ld r = t < kTableMax ? static_cast<ld>(table->log_upper(static_cast<double>(t)))
                               : std::log(range_prob(t, k, true));
    return (nu - 1) * std::log(t) - 0.5L * nu * (t / qq) * (t / qq) + r;
  };
  const ld top = log_g(tstar);
  auto g = [&](ld t) { return t > 0 ? std::exp(log_g(t) - top) : 0.0L; };
  std::vector<ld> pts{0, tstar + 80};
  for (ld d : {0.0L, 1.0L, 3.0L, 8.0L, 20.0L})
    for (ld sign : {-1.0L, 1.0L})
      if (tstar + sign * d > 0) pts.push_back(tstar + sign * d);
  if (nu < 2)  // t^(ν-1) singular or not smooth at 0
    for (int j = 1; j <= 30; ++j) pts.push_back(std::min<ld>(1, tstar) * std::ldexp(1.0L, -j));
  const ld integral = integrate(g, pts, kOuterTol);
  return std::clamp<ld>(std::exp(chi.log_norm - nu * std::log(qq) + top) * integral, 0, 1);
}

ld studentized_range(double q, int k, double df, bool upper) {
  if (k < 2) throw std::invalid_argument("studentized range: k must be >= 2");
  if (!(df > 0)) throw std::invalid_argument("studentized range: df must be > 0");
  if (!(q > 0)) return upper ? 1.0L : 0.0L;
  if (std::isinf(q)) return upper ? 0.0L : 1.0L;
  // Any pair's |Z_i - Z_j| / S exceeds q when the range does, so P(Q > q) <= C(k,2)·P(|T_ν| >
  // q/√2). Where that bound is far below the reported floor (kPFloor) the p-value is
  // reported as the bound "< 1e-300" anyway; skip the quadrature (q = 89.5, k = 9, ν = 4000).
  const ld log_bound =
      std::log(0.5L * k * (k - 1)) +
      log_t_two_sided_bound(static_cast<ld>(q) / kSqrt2, df > 1e7 ? INFINITY : static_cast<ld>(df));
  if (log_bound < std::log(static_cast<ld>(kPFloor)) - 5) return upper ? 0.0L : 1.0L;
  if (std::isinf(df) || df > 1e7) return range_prob(q, k, upper);
  if (upper && q > kFarQ) return studentized_range_far_upper(q, k, df);
  ChiScaled chi(df);
  ld nu = df;
  ld smax = chi.upper_limit();
  ld width = 1 / std::sqrt(2 * nu);
  ld s0 = std::sqrt(std::max<ld>(nu - 1, 0.5L) / nu);  // mode of the density
  ld s_low = std::sqrt((nu + k - 2) / nu);             // mode for small q (lower)
  ld s_up = std::sqrt(std::max<ld>(nu - 1, 0.5L) / (nu + 0.5L * q * q));  // small s (upper)
  std::vector<ld> pts = outer_breakpoints(nu, {s0, upper ? s_up : s_low}, width, smax);
  if (upper) {
    // Only where density × P(R > qs) can matter: bounded by U(s) = f_S(s)·min(1, C(k,2)·
    // erfc(qs/2)) (union bound over pairs, tight in the far tail). Pieces where U is below
    // e^-80 of its maximum (sampled finely) are dropped: they add < 1e-30 relative but cost
    // a full inner integral per node.
    const ld log_pairs = std::log(static_cast<ld>(k) * (k - 1));
    auto log_u = [&](ld s) -> ld {
      ld ld_ = chi.log_density(s);
      ld lw = log_pairs + log_upper_normal_d(static_cast<double>(q * s / kSqrt2));
      return ld_ + std::min<ld>(0, lw);
    };
    const int n = 400;
    ld top = -INFINITY;
    std::vector<ld> lu(n + 1);
    for (int i = 1; i <= n; ++i) top = std::max(top, lu[i] = log_u(smax * i / n));
    int first = n, last = 0;
    for (int i = 1; i <= n; ++i)
      if (lu[i] > top - 80) {
        first = std::min(first, i);
        last = i;
      }
    if (first <= last) {
      const ld lo = smax * (first - 1) / n, hi = std::min<ld>(smax, smax * (last + 1) / n);
      std::vector<ld> kept{lo, hi};
      for (ld p : pts)
        if (p > lo && p < hi) kept.push_back(p);
      pts = kept;
    }
  }
  const RangeUpperTable* table = upper ? RangeUpperTable::get(k) : nullptr;
  auto f = [&](ld s) {
    if (s <= 0) return 0.0L;
    const ld w = static_cast<ld>(q) * s;
    if (table && w < kTableMax)
      return std::exp(chi.log_density(s) +
                      static_cast<ld>(table->log_upper(static_cast<double>(w))));
    ld d = chi.density(s);
    if (d == 0) return 0.0L;
    return d * range_prob(w, k, upper);
  };
  return std::clamp<ld>(integrate(f, pts, kOuterTol), 0, 1);
}

}  // namespace

namespace {
// P(F(d1, d2) > f) = P(χ²_d1 > d1·f·S²) with S = sqrt(χ²_d2/d2) independent:
// ∫ f_S(s) Q_χ²(d1·f·s²; d1) ds. GSL's F upper tail (incomplete beta) loses digits for large
// d2 in the far tail (d2 = 1000, F = 800: 2e-5 relative; d2 = 1e6, F = 800: 0 instead of
// 6.3e-176); this integral keeps relative accuracy (checked against R's pf in
// tests/analysis/test_vs_r.cpp). For d1 = 1 the χ² tail is erfc(sqrt(x/2)) in long double.
ld f_upper(double f, double d1, double d2) {
  auto chi_tail = [d1](ld x) -> ld {
    if (x <= 0) return 1;
    if (d1 == 1) return std::erfc(std::sqrt(0.5L * x));
    return gsl_sf_gamma_inc_Q(0.5 * d1, static_cast<double>(0.5L * x));
  };
  if (std::isinf(d2) || d2 > 1e9) return chi_tail(static_cast<ld>(d1) * f);
  ChiScaled chi(d2);
  const ld nu = d2, smax = chi.upper_limit();
  const ld s0 = std::sqrt(std::max<ld>(nu - 1, 0.5L) / nu);
  // Where density × tail peaks for a large f (the tail then decays like e^{-d1 f s²/2}).
  const ld s_tail = std::sqrt(std::max<ld>(nu + d1 - 2, 0.5L) / (nu + d1 * static_cast<ld>(f)));
  const ld width = 1 / std::sqrt(2 * nu);
  std::vector<ld> pts = outer_breakpoints(nu, {s0, s_tail}, width, smax);
  auto g = [&](ld s) {
    ld d = chi.density(s);
    return d == 0 ? 0.0L : d * chi_tail(static_cast<ld>(d1) * f * s * s);
  };
  return std::clamp<ld>(integrate(g, pts, 1e-13L), 0, 1);
}
}  // namespace

double f_upper_p(double f, double d1, double d2) {
  gsl_quiet();
  if (!std::isfinite(f) || !(d1 > 0) || !(d2 > 0)) return std::numeric_limits<double>::quiet_NaN();
  if (f <= 0) return 1.0;
  return clamp_p(static_cast<double>(f_upper(f, d1, d2)));
}

double t_two_sided_p(double t, double df) {
  if (!std::isfinite(t) || !(df > 0)) return std::numeric_limits<double>::quiet_NaN();
  return f_upper_p(t * t, 1.0, df);  // P(|T| > |t|) = P(F(1, df) > t²)
}

double studentized_range_cdf(double q, int k, double df) {
  return static_cast<double>(studentized_range(q, k, df, false));
}

double studentized_range_sf(double q, int k, double df) {
  return static_cast<double>(studentized_range(q, k, df, true));
}

double studentized_range_quantile(double p, int k, double df) {
  if (!(p > 0 && p < 1)) throw std::invalid_argument("studentized range quantile: p in (0, 1)");
  // Work on the smaller tail so the root keeps relative accuracy.
  bool upper = p > 0.5;
  double target = upper ? 1 - p : p;
  auto g = [&](double q) {
    double v = upper ? studentized_range_sf(q, k, df) : studentized_range_cdf(q, k, df);
    return upper ? target - v : v - target;  // increasing in q
  };
  double a = 0, b = 1;
  double fa = -target, fb;
  // Upper quantiles lie between one pair's and the Bonferroni bound over all C(k,2) pairs:
  // P(|T| > q/√2) <= P(Q > q) <= C(k,2)·P(|T| > q/√2). Both are cheap t quantiles and give a
  // bracket a few root steps wide (no doubling search).
  if (upper && df <= 1e7) {
    const double pairs = 0.5 * k * (k - 1);
    const double lo = kSqrt2d * t_quantile(1 - target / 2, df);
    const double hi = kSqrt2d * t_quantile(1 - target / (2 * pairs), df);
    // The root is searched in log q for log P(Q > q): in the tail P(Q > q) falls like q^-ν,
    // a straight line there, so the secant steps converge in a few evaluations even when the
    // bracket spans decades (ν near 1: false position on P itself took ~100 evaluations,
    // 0.5 s per quantile at k = 100, and Games–Howell of 100 groups of 2 needs thousands).
    const double log_target = std::log(target);
    auto h = [&](double u) {
      return log_target - std::log(studentized_range_sf(std::exp(u), k, df));
    };
    // The bracket grows from the one-pair bound by factors of 4 up to the Bonferroni bound: P
    // far out in the tail (the Bonferroni bound at ν near 1 is ~1e4 times the root) costs ~50
    // times more to integrate than near the root.
    double ulo = std::log(lo), hlo = h(ulo);
    const double ubound = std::log(hi);
    double uhi = ulo, hhi = hlo;
    while (hhi < 0 && uhi < ubound) {
      ulo = uhi;
      hlo = hhi;
      uhi = std::min(uhi + std::log(4.0), ubound);
      hhi = h(uhi);
    }
    if (hlo <= 0 && hhi >= 0 && std::isfinite(hlo) && std::isfinite(hhi)) {
      if (hlo == 0) return std::exp(ulo);
      if (hhi == 0) return std::exp(uhi);
      return std::exp(find_root(h, ulo, uhi, hlo, hhi, 1e-15));
    }
  }
  fb = g(b);
  while (fb < 0) {
    a = b;
    fa = fb;
    b *= 2;
    fb = g(b);
    if (b > 1e6) break;
  }
  return find_root(g, a, b, fa, fb, 1e-13);
}

double noncentral_t_cdf(double t, double df, double delta) {
  if (!(df > 0)) throw std::invalid_argument("noncentral t: df must be > 0");
  // T = (Z + δ) / S, so P(T <= t) = ∫ f_S(s) Φ(t s - δ) ds; the upper form is used when the
  // integrand's Φ is near 1 so the complement keeps its digits.
  ChiScaled chi(df);
  ld nu = df;
  ld smax = chi.upper_limit();
  ld width = 1 / std::sqrt(2 * nu);
  ld s0 = std::sqrt(std::max<ld>(nu - 1, 0.5L) / nu);
  std::vector<ld> pts = outer_breakpoints(nu, {s0}, width, smax);
  if (t != 0) {
    ld sc = static_cast<ld>(delta) / t;  // where the Φ switches
    if (sc > 0 && sc < smax) pts.push_back(sc);
  }
  // The normal tails in double (summed in long double): relative error ~1e-15, far inside what
  // the interval needs (its roots are solved to 1e-12), at less cost than long double erfcl.
  // The exponent of the density is a difference of terms ~ν (thousands): summed in long
  // double, so that its rounding (not ~ν·eps) is what the double exp sees; otherwise that
  // noise (3e-13 at ν = 6600) keeps the adaptive rule from converging.
  // For ν > 2 it is written relative to the mode s0 (ν s0² = ν - 1), x = s/s0 - 1:
  // log f(s) - log f(s0) = (ν - 1)(log1p(x) - x - x²/2), whose rounding is ~ν·eps·|x| (1e-14
  // where the mass is), all in double.
  const double tt = t, dd = delta, nud = df;
  const double s0d = nud > 2 ? std::sqrt((nud - 1) / nud) : 1;
  const double lmode = static_cast<double>(chi.log_density(s0d));
  // For ν <= 2 the exponent's terms are of order 1 (no cancellation): double, as below — in
  // long double (expl, logl) it was 70 % of `palplab stats` on 100 groups of 2 (Cohen's d
  // intervals at df 2).
  const double lnorm = static_cast<double>(chi.log_norm);
  auto dens = [&](ld sl) {
    if (!(sl > 0)) return 0.0;
    if (!(nud > 2)) {
      const double sd = static_cast<double>(sl);
      return std::exp(lnorm + (nud - 1) * std::log(sd) - 0.5 * nud * sd * sd);
    }
    const double x = static_cast<double>(sl) / s0d - 1;
    return std::exp(lmode + (nud - 1) * (std::log1p(x) - x - 0.5 * x * x));
  };
  auto lower = [&](ld s) {
    return static_cast<ld>(dens(s) * upper_normal_d(dd - tt * static_cast<double>(s)));
  };
  auto upper = [&](ld s) {
    return static_cast<ld>(dens(s) * upper_normal_d(tt * static_cast<double>(s) - dd));
  };
  // The value is 1 - upper when upper < 1/2, else lower. Where a normal approximation puts the
  // CDF well below 1/2, lower is integrated first: lower + upper = 1 (to the quadrature's
  // 1e-12), so lower < 0.45 proves upper > 1/2, and lower is the value the upper-first order
  // returns, unchanged; it saves one of the two integrals of half the root's evaluations.
  const double approx = 0.5 * std::erfc((dd - tt) / std::sqrt(2 * (1 + tt * tt / (2 * nud))));
  if (approx < 0.25) {
    const ld low = integrate(lower, pts, 1e-12L);
    if (low < 0.45L) return static_cast<double>(std::clamp<ld>(low, 0, 1));
  }
  ld up = integrate(upper, pts, 1e-12L);
  if (up < 0.5L) return static_cast<double>(1 - up);
  return static_cast<double>(std::clamp<ld>(integrate(lower, pts, 1e-12L), 0, 1));
}

double noncentral_t_delta_for_cdf(double t, double df, double p) {
  // The CDF falls from 1 to 0 as delta grows; bracket around t.
  auto g = [&](double d) { return noncentral_t_cdf(t, df, d) - p; };
  // Start from the normal approximation T ≈ N(δ, 1 + δ²/(2ν)): δ0 = t - z_p·σ, bracketed by
  // ±σ/2 (widened below if that is not enough), which saves most of the root's evaluations.
  gsl_quiet();
  const double sigma = std::sqrt(1 + t * t / (2 * df));
  const double d0 = t - gsl_cdf_ugaussian_Pinv(p) * sigma;
  double step = 0.5 * sigma;
  double a = d0 - step, b = d0 + step;
  double fa = g(a), fb = g(b);
  for (int i = 0; i < 60 && fa < 0; ++i) {
    a -= step;
    step *= 2;
    fa = g(a);
  }
  for (int i = 0; i < 60 && fb > 0; ++i) {
    b += step;
    step *= 2;
    fb = g(b);
  }
  return find_root(g, a, b, fa, fb, 1e-12);
}

double noncentral_f_cdf(double x, double d1, double d2, double lambda) {
  if (!(d1 > 0) || !(d2 > 0) || !(lambda >= 0) || !std::isfinite(lambda))
    throw std::invalid_argument("noncentral F: need d1, d2 > 0 and a finite lambda >= 0");
  gsl_quiet();
  if (!(x > 0)) return 0;
  if (std::isinf(x)) return 1;
  // y and 1 - y from the ratio directly, so neither loses digits when d1 x << d2 or >> d2.
  const double y = d1 * x / (d1 * x + d2), y1 = d2 / (d1 * x + d2);
  const double a = 0.5 * d1, b = 0.5 * d2, mu = 0.5 * lambda;
  auto ibeta = [&](double aj) {
    // I_y(aj, b) = 1 - I_{1-y}(b, aj): use the form whose argument is the smaller, as GSL's
    // continued fraction converges best there.
    return y <= 0.5 ? gsl_sf_beta_inc(aj, b, y) : 1 - gsl_sf_beta_inc(b, aj, y1);
  };
  if (mu == 0) return std::clamp(ibeta(a), 0.0, 1.0);
  auto log_pois = [&](double j) { return j * std::log(mu) - mu - std::lgamma(j + 1); };
  const double j0 = std::floor(mu);
  long double sum = 0;
  // Upward from the mode (j0 included).
  for (double j = j0;; ++j) {
    const double w = std::exp(log_pois(j));
    const double ib = ibeta(a + j);
    sum += static_cast<long double>(w) * ib;
    // Omitted: Σ_{i>j} w_i I_y(a + i, b) <= I_y(a + j + 1, b) · P(J > j) <= ib · P(J > j).
    const double tail = gsl_cdf_poisson_Q(static_cast<unsigned>(j), mu);
    if (ib * tail <= 1e-17 * static_cast<double>(sum) || ib * tail < 1e-300 || ib == 0) break;
    if (j > j0 + 1e7) break;  // unreachable: the Poisson tail falls like exp(-j²/2μ)
  }
  // Downward from j0 - 1.
  for (double j = j0 - 1; j >= 0; --j) {
    // Omitted with this term still to add: Σ_{i<=j} w_i I <= P(J <= j).
    const double rest = gsl_cdf_poisson_P(static_cast<unsigned>(j), mu);
    if (rest <= 1e-17 * static_cast<double>(sum) || rest < 1e-300) break;
    sum += static_cast<long double>(std::exp(log_pois(j))) * ibeta(a + j);
  }
  return std::clamp(static_cast<double>(sum), 0.0, 1.0);
}

double noncentral_f_lambda_for_cdf(double f, double d1, double d2, double p) {
  if (!(p > 0 && p < 1)) throw std::invalid_argument("noncentral F: p must lie in (0, 1)");
  auto g = [&](double l) { return noncentral_f_cdf(f, d1, d2, l) - p; };
  const double g0 = g(0);
  if (g0 <= 0) return 0;
  // The CDF at f falls to 0 as λ grows; E[F] ≈ (d1 + λ)/d1, so λ ≈ d1·f is near the median.
  // Bracket by doubling from there.
  double a = 0, fa = g0;
  double b = std::max(1.0, d1 * f);
  double fb = g(b);
  for (int i = 0; i < 200 && fb > 0; ++i) {
    a = b;
    fa = fb;
    b *= 2;
    fb = g(b);
  }
  if (fb > 0) return b;  // λ beyond ~1e60: cannot happen for a finite F
  return find_root(g, a, b, fa, fb, 1e-13);
}

FEffectCi f_effect_ci(double F, double df1, double df2, double level) {
  FEffectCi c;
  c.level = level;
  if (!std::isfinite(F) || !(F >= 0) || !(df1 > 0) || !(df2 > 0) || !std::isfinite(df1) ||
      !std::isfinite(df2) || !(level > 0 && level < 1))
    return c;
  // The sum needs ~sqrt(λ) terms: beyond λ ~ 1e7 (F·df1, where the upper bound lies) the
  // interval is left undefined rather than spending seconds; its η² bounds would be > 0.9999
  // for any n below 1000.
  if (F * df1 > 1e7) return c;
  const double tail = 0.5 * (1 - level);
  c.lambda_low = noncentral_f_lambda_for_cdf(F, df1, df2, 1 - tail);
  c.lambda_high = noncentral_f_lambda_for_cdf(F, df1, df2, tail);
  const double n = df1 + df2 + 1;
  c.pve_low = c.lambda_low / (c.lambda_low + n);
  c.pve_high = c.lambda_high / (c.lambda_high + n);
  c.defined = true;
  return c;
}

}  // namespace palplab::analysis
