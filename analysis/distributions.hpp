#pragma once
// Probability distributions for the tests: thin, accuracy-minded wrappers over GSL for the
// classical ones, and our own studentized range (Tukey HSD, Games–Howell) and noncentral t
// (effect-size confidence intervals), both by adaptive quadrature in long double.
//
// p-values: every function returning a p-value clamps it to at least kPFloor, so an underflow
// is reported as the bound "p < 1e-300" (see p_is_bound), never as 0.

namespace palplab::analysis {

inline constexpr double kPFloor = 1e-300;
inline double clamp_p(double p) {
  return p < kPFloor ? kPFloor : (p > 1 ? 1 : p);
}
inline bool p_is_bound(double p) {
  return p <= kPFloor;
}

// Turns GSL's error handler off once (GSL would otherwise abort the process on a domain
// error); every function below calls it, so callers need not.
void gsl_quiet();

// Two-sided p of Student's t with `df` (> 0, need not be an integer) degrees of freedom,
// computed as P(F(1, df) > t²): GSL's t CDF loses accuracy for df > 30, its F CDF does not.
double t_two_sided_p(double t, double df);
// Upper-tail p of F(d1, d2) at f.
double f_upper_p(double f, double d1, double d2);
// Upper-tail p of chi-squared(df) at x.
double chi2_upper_p(double x, double df);
// Two-sided p of a standard normal z.
double normal_two_sided_p(double z);
// Quantile t_{p, df} (0 < p < 1), through the F quantile for the same reason.
double t_quantile(double p, double df);

// Studentized range Q(k, ν): the range of k independent N(0,1) divided by an independent
// sqrt(χ²_ν/ν). k >= 2, ν > 0 (ν = +inf allowed: the range of k normals). q >= 0.
// cdf = P(Q <= q); sf = P(Q > q), computed directly (not 1 - cdf) so small p-values keep
// their relative accuracy. Accuracy: ~1e-13 relative against mpmath (tests/analysis).
double studentized_range_cdf(double q, int k, double df);
double studentized_range_sf(double q, int k, double df);
// The q with cdf(q) = p (0 < p < 1), by bracketing and Illinois regula falsi.
double studentized_range_quantile(double p, int k, double df);

// Noncentral t with df degrees of freedom and noncentrality delta: P(T <= t).
double noncentral_t_cdf(double t, double df, double delta);
// The delta with noncentral_t_cdf(t, df, delta) = p (the CDF decreases in delta); used to
// invert a t statistic into a confidence interval for its noncentrality.
double noncentral_t_delta_for_cdf(double t, double df, double p);

// Root of a continuous f on [a, b] with f(a), f(b) of opposite signs (Illinois method).
template <class F>
double find_root(const F& f, double a, double b, double fa, double fb, double rel_tol = 1e-14) {
  int side = 0;
  double c = a;
  for (int it = 0; it < 300; ++it) {
    c = (a * fb - b * fa) / (fb - fa);
    if (!(c > a && c < b) && !(c > b && c < a)) c = 0.5 * (a + b);
    double fc = f(c);
    if (fc == 0) return c;
    if ((fc > 0) == (fb > 0)) {
      b = c;
      fb = fc;
      if (side == -1) fa /= 2;
      side = -1;
    } else {
      a = c;
      fa = fc;
      if (side == 1) fb /= 2;
      side = 1;
    }
    double scale = (a < 0 ? -a : a) + (b < 0 ? -b : b);
    if ((a > b ? a - b : b - a) <= rel_tol * scale + 1e-300) break;
  }
  return c;
}

}  // namespace palplab::analysis
