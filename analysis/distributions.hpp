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

// Noncentral F(d1, d2, λ) (d1, d2 > 0, need not be integers; λ >= 0): P(F <= x), as the
// Poisson(λ/2)-weighted sum of regularized incomplete beta functions
//   Σ_j e^{-λ/2} (λ/2)^j / j! · I_y(d1/2 + j, d2/2),  y = d1 x / (d1 x + d2),
// summed outward from the Poisson mode and truncated when the bound on the omitted terms
// (upward: I_y(d1/2 + j + 1, d2/2) · P(J > j), since I_y falls with j; downward: P(J < j))
// is below 1e-17 of the sum. Absolute accuracy ~1e-15 (tests/analysis: λ = 0 against the
// central F, truncation against the untruncated sum, R's pf(ncp =) on a grid).
double noncentral_f_cdf(double x, double d1, double d2, double lambda);
// The λ >= 0 with noncentral_f_cdf(f, d1, d2, λ) = p (the CDF falls as λ grows); 0 when even
// λ = 0 gives a CDF <= p (the interval bound then sits at its lower limit, Steiger 2004).
double noncentral_f_lambda_for_cdf(double f, double d1, double d2, double p);

// Confidence interval for the effect size of an F test by inverting the noncentral F in its
// noncentrality λ (Steiger 2004, Psychological Methods 9:164; Smithson 2003): the two-sided
// `level` interval [λ_lo, λ_hi] solves CDF(F; λ_lo) = (1 + level)/2, CDF(F; λ_hi) = (1 -
// level)/2 (a bound is 0 when λ = 0 already gives less). λ converts to the population
// proportion of variance explained, λ / (λ + n), with n = df1 + df2 + 1 (the number of
// observations of a one-way design; for a term of a larger model, Smithson's convention for
// partial η²). The sample η² and ω² both estimate this one population quantity, so it is the
// interval for both (and for partial η²).
struct FEffectCi {
  double level = 0.95;
  double lambda_low = 0, lambda_high = 0;  // noncentrality bounds
  double pve_low = 0, pve_high = 0;  // population η² (= ω², partial η²) bounds, in [0, 1)
  bool defined = false;  // false for a non-finite F or df, or F·df1 > 1e7 (too many terms)
};
FEffectCi f_effect_ci(double F, double df1, double df2, double level = 0.95);

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
