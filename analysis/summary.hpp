#pragma once
// The full one-way analysis of a grouped sample, as `palplab stats` prints it and the report
// uses it: descriptives per group, classical and Welch ANOVA, every pairwise t-test (Holm and
// Bonferroni adjusted) with Hedges' g, Tukey–Kramer, Games–Howell, Levene, Brown–Forsythe,
// Shapiro–Wilk per group, Kruskal–Wallis and pairwise Mann–Whitney. JSON keys: see
// docs/FORMATS.md.
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "analysis/anova.hpp"
#include "analysis/descriptives.hpp"
#include "analysis/distributions.hpp"
#include "analysis/grouped.hpp"
#include "analysis/normality.hpp"
#include "analysis/posthoc.hpp"
#include "analysis/two_sample.hpp"

namespace palplab::analysis {

struct StatsOptions {
  DfMode df_mode = DfMode::Exact;  // for the pairwise Welch tests
  bool welch_pairwise = true;      // false: Student's pooled-variance t
  bool post_hoc = true;            // Tukey–Kramer and Games–Howell (the slowest part)
  // Equivalence margins [low, high] on mean(a) - mean(b), in the data's units; when set, every
  // pair also gets a TOST (tost_welch) and a verdict. alpha is the TOST's level.
  std::optional<std::pair<double, double>> margins;
  double alpha = 0.05;
};

struct StatsSummary {
  std::vector<std::string> names;
  std::vector<Descriptives> groups;
  std::vector<ShapiroWilk> shapiro;  // per group; defined = false when n < 3 or constant
  Anova anova;
  // 95 % interval of the population proportion of variance explained (the η² and ω² of the
  // classical ANOVA), by inverting the noncentral F (f_effect_ci); defined = false when the
  // ANOVA is undefined.
  FEffectCi anova_effect_ci;
  WelchAnova welch;
  std::vector<PairwiseT> pairwise;
  std::vector<MannWhitney> mann_whitney;  // same order as pairwise
  std::vector<Equivalence> equivalence;   // same order as pairwise; empty without margins
  std::vector<RangeComparison> tukey, games_howell;
  Anova levene, brown_forsythe;
  // log10 of F where F = MS_between / MS_within exceeds the range of a double (F is then inf,
  // its p computed from log F, f_upper_p_log); NaN otherwise.
  double anova_log10_F = std::numeric_limits<double>::quiet_NaN();
  double levene_log10_F = std::numeric_limits<double>::quiet_NaN();
  double brown_forsythe_log10_F = std::numeric_limits<double>::quiet_NaN();
  KruskalWallis kruskal;
  StatsOptions options;
};

StatsSummary summarize(const GroupedData& data, const StatsOptions& options = {});

// APA style pieces: "p = .003", "p < .001", "p > .999"; numbers to 2 decimals, from 1e6 on in
// scientific notation ("t(2) = -1.73e+200").
std::string apa_p(double p);
// "F(2, 27) = 23.68, p < .001" (fractional df get 2 decimals).
std::string apa_f(double F, double df1, double df2, double p);
// apa_f of an ANOVA (or Levene / Brown–Forsythe), or "undefined (no variation within
// groups)" when it has none.
std::string apa_anova(const Anova& a);
// Levene's and Brown-Forsythe's test (an ANOVA of the absolute deviations from each group's mean
// or median): when undefined, it is those deviations that do not vary (groups of 2 never do),
// not the data.
std::string apa_spread_test(const Anova& a, double log10_F);
// "t(17) = 3.43, p = .003".
std::string apa_t(double t, double df, double p);
// "1e-300" style for tables: "< 1e-300" when the p-value is an underflow bound.
std::string format_p(double p);

// A statistic (t, F, q, g) with `decimals` decimals, from 1e6 on in scientific notation with as
// many decimals ("1.73e+200", never cut); "n/a" when not finite. As the APA lines print them.
std::string stat_text(double v, int decimals);
// An F for text: stat_text, or 10^log10_F in scientific notation when F is beyond the range of
// a double (Anova::log10_F finite: "3.00e+400").
std::string f_text(double F, double log10_F, int decimals);
// "< 1e-300" style for an adjusted p whose raw p was a bound (p_holm_is_bound): "< 3e-300";
// format_p otherwise.
std::string format_p(double p, bool is_bound);

nlohmann::json to_json(const StatsSummary& s);
// Human-readable tables and APA lines.
std::string to_text(const StatsSummary& s);

}  // namespace palplab::analysis
