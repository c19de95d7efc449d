#pragma once
// Multiple comparisons: p-value adjustments, all pairwise t-tests, Tukey–Kramer HSD and
// Games–Howell (both on our studentized range distribution).
#include <cstddef>
#include <vector>

#include "analysis/anova.hpp"
#include "analysis/two_sample.hpp"

namespace palplab::analysis {

// Holm (1979) step-down and Bonferroni adjusted p-values, in the input order (as R's
// p.adjust). NaN entries are left out of the family and stay NaN. `is_bound` (optional)
// receives, per entry, whether the adjusted p is itself a bound: it was computed from a p that
// is the underflow bound (p_is_bound: p < 1e-300), so m·1e-300 = 3e-300 means p < 3e-300 (for
// Holm: the running maximum was set by such a term and by no exact one; an adjusted p of 1 is
// exact).
std::vector<double> holm(const std::vector<double>& p, std::vector<bool>* is_bound = nullptr);
std::vector<double> bonferroni(const std::vector<double>& p, std::vector<bool>* is_bound = nullptr);

struct PairwiseT {
  int a = 0, b = 0;  // group indices, a < b
  TTest test;
  double p_holm = 1, p_bonferroni = 1;  // over the k(k-1)/2 comparisons
  // The adjusted p is an upper bound (built from a test p at the 1e-300 floor; see holm).
  bool p_holm_is_bound = false, p_bonferroni_is_bound = false;
  EffectSize effect;
};
// Every pair (a < b, in group order) with Welch's (welch = true) or Student's t.
std::vector<PairwiseT> pairwise_t(const Groups& groups, bool welch = true,
                                  DfMode mode = DfMode::Exact);

struct RangeComparison {
  int a = 0, b = 0;      // group indices, a < b
  double mean_diff = 0;  // mean(a) - mean(b)
  double se = 0;         // sqrt(MS/2 (1/na + 1/nb)) (Tukey) or sqrt((va/na + vb/nb)/2)
  double q = 0;          // |mean_diff| / se, studentized range statistic
  double df = 0;
  double p = 1;                    // P(Q(k, df) > q)
  double ci_low = 0, ci_high = 0;  // simultaneous 95 % interval for mean_diff
  bool defined = true;
};
// Critical values q with P(Q(k, ν) <= q) = level for the df of many comparisons at once
// (Games–Howell has one df per pair). Up to kDirectMax distinct df are solved one by one; more
// are interpolated in x = 1/ν on Chebyshev nodes (each node one root search), separately below
// and above kSmallDf (below it, ν of groups of 2 or 3, in log q: q grows steeply as ν -> 1),
// each piece accepted only when three pairs' df solved directly agree to kInterpolationTol
// relative, else its df are solved directly.
class RangeQuantiles {
 public:
  static constexpr std::size_t kDirectMax = 12;
  static constexpr double kSmallDf = 4;
  static constexpr int kMaxNodes = 33;
  static constexpr double kInterpolationTol = 1e-11;
  RangeQuantiles(double level, int k, const std::vector<double>& dfs);
  double operator()(double df) const;
  bool interpolated() const { return !pieces_.empty(); }

 private:
  struct Piece {  // a Chebyshev interpolant of q (or log q) over x in [x_lo, x_hi]
    double x_lo = 0, x_hi = 0;
    bool log_q = false;
    std::vector<double> nodes, values;
    double operator()(double x) const;
  };
  // Interpolates the df of `dfs` (sorted, distinct) or, failing that, adds them to direct_df_.
  void cover(const std::vector<double>& dfs, bool log_q);
  double level_;
  int k_;
  std::vector<double> direct_df_, direct_q_;  // sorted df and their quantiles
  std::vector<Piece> pieces_;
};

// Tukey–Kramer HSD (pooled MS_within and df of the ANOVA; as R's TukeyHSD).
std::vector<RangeComparison> tukey_kramer(const Groups& groups, double level = 0.95);
// Games–Howell: per pair the Welch SE and Welch–Satterthwaite df.
std::vector<RangeComparison> games_howell(const Groups& groups, double level = 0.95);

}  // namespace palplab::analysis
