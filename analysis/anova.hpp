#pragma once
// One-way designs: classical and Welch ANOVA, Levene / Brown–Forsythe homogeneity of
// variance, Kruskal–Wallis. A design is `groups`: #groups samples, each a vector of values
// (any common shift of all values leaves every result here unchanged, see decimal.hpp).
#include <limits>
#include <vector>

namespace palplab::analysis {

using Groups = std::vector<std::vector<double>>;

struct Anova {
  double df_between = 0, df_within = 0;
  double ss_between = 0, ss_within = 0, ms_between = 0, ms_within = 0;
  double F = 0, p = 1;
  double eta_squared = 0;    // SS_between / SS_total (= R²)
  double omega_squared = 0;  // (SS_between - df_between·MS_within) / (SS_total + MS_within)
  double residual_sd = 0;    // sqrt(MS_within)
  bool defined = true;       // false when there is no within-group variance (F = ∞)
  // log10 F when F = MS_between / MS_within exceeds the range of a double although MS_within >
  // 0 (F is then ∞ and p computed from log F, f_upper_p_log: a group constant at 1e100 beside
  // one spread by 1e-100; Levene of spreads ~1e-160, whose MS_within underflows a double); NaN
  // otherwise. Computed from the sums of squares in long double.
  double log10_F = std::numeric_limits<double>::quiet_NaN();
};
// Requires >= 2 groups, each with >= 1 value, and N > #groups.
Anova oneway_anova(const Groups& groups);

struct WelchAnova {
  double df_between = 0, df_within = 0;  // k - 1 and Welch's fractional denominator df
  double F = 0, p = 1;
  // F·df1 / (F·df1 + df2): the partial η² implied by the test (for the classical ANOVA this
  // equals SS_between / SS_total); what R's effectsize reports for oneway.test.
  double eta_squared = 0;
  bool defined = true;  // false when a group has zero variance (its weight n/s² is infinite)
};
// Welch (1951) heteroscedastic one-way ANOVA, as R's oneway.test(var.equal = FALSE).
// Requires every group to have >= 2 values.
WelchAnova welch_anova(const Groups& groups);

// Homogeneity of variance: the classical ANOVA of |x - centre of its group|, centre = mean
// (Levene 1960) or median (Brown & Forsythe 1974; what car::leveneTest does by default).
enum class LeveneCentre { Mean, Median };
Anova levene(const Groups& groups, LeveneCentre centre);

struct KruskalWallis {
  double H = 0, df = 0, p = 1;
  double tie_correction = 1;  // 1 - Σ(t³ - t)/(N³ - N), H already divided by it
  bool defined = true;        // false when every value is tied
};
// Kruskal–Wallis rank-sum test with tie correction and the chi-squared approximation (as R's
// kruskal.test).
KruskalWallis kruskal_wallis(const Groups& groups);

// Mid-ranks (1-based, ties get their average rank) of `x`; `tie_sum` (optional) receives
// Σ(t³ - t) over groups of ties.
std::vector<double> midranks(const std::vector<double>& x, double* tie_sum = nullptr);

}  // namespace palplab::analysis
