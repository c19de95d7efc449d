#pragma once
// Two-sample comparisons: Student and Welch t-tests, Mann–Whitney, Cohen's d / Hedges' g.
#include <vector>

namespace palplab::analysis {

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

struct EffectSize {
  double d = 0;  // Cohen's d = (mean a - mean b) / pooled SD
  double g = 0;  // Hedges' g = J·d, J = Γ(ν/2) / (sqrt(ν/2) Γ((ν-1)/2)), ν = #a + #b - 2 (exact)
  double d_ci_low = 0, d_ci_high = 0;  // by inverting the noncentral t (Steiger & Fouladi)
  double g_ci_low = 0, g_ci_high = 0;  // the d interval times J
  double level = 0.95;
  bool defined = true;  // false when the pooled SD is 0
};
EffectSize cohens_d(const std::vector<double>& a, const std::vector<double>& b,
                    double level = 0.95);

}  // namespace palplab::analysis
