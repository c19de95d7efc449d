#pragma once
// Two-sample comparisons: Student and Welch t-tests, Mann–Whitney, Cohen's d / Hedges' g.
#include <string>
#include <vector>

namespace palplab::analysis {

// Two-sided p of Student's t, P(|T| > |t|), as t_two_sided_p (distributions.hpp) but for every
// t: t_two_sided_p squares t, which overflows a double beyond |t| ~ 1.3e154 (a t of 1.7e200,
// one group constant at 1e100 beside one spread by 1e-100, gave p = NaN). There the leading
// term of the incomplete beta series, x^a / (a B(a, 1/2)) with x = df / t² and a = df/2, in
// logarithms, is exact to relative O(x) < 1e-290. Clamped to [kPFloor, 1]; |t| = inf gives
// the bound; NaN only for a NaN t or df <= 0.
double t_two_sided_p_wide(double t, double df);
// One-sided P(T > t), clamped to [kPFloor, 1] (a tail below 1e-300 is the bound, p_is_bound).
double t_upper_p(double t, double df);
// Upper-tail p of F(d1, d2) at F = exp(log_f), also for F beyond the range of a double (an F
// of MS_between / MS_within = 1e400): f_upper_p below 1e300, above it the leading term of
// I_x(d2/2, d1/2), x = d2 / (d1 F), in logarithms (exact to relative O(x)). Clamped to
// [kPFloor, 1].
double f_upper_p_log(double log_f, double d1, double d2);

// Degrees of freedom of Welch's test: `Exact` is the Welch–Satterthwaite value; `Floor`
// truncates it to an integer (at least 1) as MINITAB reports it, and the p-value is then
// computed with the truncated df, which reproduces MINITAB-based publications.
enum class DfMode { Exact, Floor };

struct TTest {
  double t = 0, df = 0, p = 1;     // two-sided p
  double mean_diff = 0;            // mean(a) - mean(b)
  double se = 0;                   // standard error of mean_diff
  double ci_low = 0, ci_high = 0;  // 95 % CI of mean_diff with the same df
  double df_exact = 0;             // Welch–Satterthwaite before any flooring (= df for Student)
  bool welch = false;
  bool defined = true;  // false when both samples are constant (se = 0)
};
// a, b  #a, #b >= 2 values each.
TTest student_t(const std::vector<double>& a, const std::vector<double>& b);
TTest welch_t(const std::vector<double>& a, const std::vector<double>& b,
              DfMode mode = DfMode::Exact);
// Only mean_diff, se, df_exact, df and welch of welch_t (same values; t, p and the interval
// are left at their defaults): for Games–Howell, which needs the SE and df, not the t test.
TTest welch_t_moments(const std::vector<double>& a, const std::vector<double>& b,
                      DfMode mode = DfMode::Exact);

struct MannWhitney {
  double W = 0;         // Σ ranks of a - #a(#a+1)/2 (R's W; the Mann–Whitney U of a)
  double z = 0;         // normal-approximation z (0 when exact)
  double p = 1;         // two-sided
  bool exact = false;   // exact null distribution (no ties and #a, #b < 50), as R's default
  bool defined = true;  // false when every value is tied
};
// Two-sided Wilcoxon–Mann–Whitney rank-sum test, following R's wilcox.test defaults: exact
// when both samples have < 50 values and there are no ties, else the normal approximation
// with tie-corrected variance and continuity correction.
MannWhitney mann_whitney(const std::vector<double>& a, const std::vector<double>& b);
// The same test on samples already sorted ascending (no NaN): a linear merge instead of a sort
// of the pooled sample, for callers that compare every pair of many groups.
MannWhitney mann_whitney_sorted(const std::vector<double>& a, const std::vector<double>& b);

struct EffectSize {
  double d = 0;  // Cohen's d = (mean a - mean b) / pooled SD
  double g = 0;  // Hedges' g = J·d, J = Γ(ν/2) / (sqrt(ν/2) Γ((ν-1)/2)), ν = #a + #b - 2 (exact)
  double d_ci_low = 0, d_ci_high = 0;  // by inverting the noncentral t (Steiger & Fouladi)
  double g_ci_low = 0, g_ci_high = 0;  // the d interval times J
  double level = 0.95;
  // Which t the interval inverts: "student" (pooled SE, ν = #a + #b - 2) or "welch" (Welch's
  // t and df, the interval of δ = Δ/SE_welch rescaled by SE_welch / pooled SD), so that the
  // interval excludes 0 exactly when the test beside it has p < 1 - level.
  const char* ci_method = "student";
  bool defined = true;  // false when the pooled SD is 0
};
EffectSize cohens_d(const std::vector<double>& a, const std::vector<double>& b,
                    double level = 0.95);
// The same d and g without the interval (its two root searches on the noncentral t skipped; the
// interval fields are 0): for callers that need the point values only, many times (power).
EffectSize cohens_d_point(const std::vector<double>& a, const std::vector<double>& b,
                          double level = 0.95);
// Cohen's d / Hedges' g (same point values as cohens_d) with the interval that matches the
// Welch test `w` (welch_t(a, b, mode) with the same mode, so floored df stay consistent).
EffectSize cohens_d_welch(const std::vector<double>& a, const std::vector<double>& b,
                          const TTest& w, double level = 0.95);

// Two one-sided tests (TOST, Schuirmann 1987) of equivalence of mean(a) - mean(b) within the
// margins [low, high] (low < high, in the data's units), on Welch's t and df (the `mode` of the
// accompanying Welch test): H0 Δ <= low rejected with p_low = P(T > (Δ̂ - low)/SE), H0 Δ >= high
// with p_high = P(T < (Δ̂ - high)/SE); p = max(p_low, p_high). The (1 - 2α) interval of Δ lies
// inside the margins exactly when p < α. verdict: "equivalent" (p < α), else "different"
// (Welch's two-sided p < α), else "inconclusive" — never "no difference".
struct Equivalence {
  double low = 0, high = 0, alpha = 0.05;
  double t_low = 0, t_high = 0, df = 0, se = 0, mean_diff = 0;
  double p_low = 1, p_high = 1, p = 1;
  double ci_low = 0, ci_high = 0;  // (1 - 2α) interval of mean_diff
  double p_difference = 1;         // Welch's two-sided p (same df)
  std::string verdict;
  bool defined = true;  // false when SE = 0
};
Equivalence tost_welch(const std::vector<double>& a, const std::vector<double>& b, double low,
                       double high, double alpha = 0.05, DfMode mode = DfMode::Exact);

}  // namespace palplab::analysis
