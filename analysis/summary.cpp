#include "analysis/summary.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <future>
#include <limits>
#include <map>
#include <sstream>

#include "analysis/csv.hpp"
#include "analysis/distributions.hpp"
#include "analysis/parallel.hpp"
#include "common/escape.hpp"
#include "common/format.hpp"
#include "common/input_error.hpp"

namespace palplab::analysis {

namespace {

// printf into a string of the size needed: never cut (a fixed buffer cut a t of 1.7e200 printed
// with %.2f to 62 of its 201 digits, and table rows with long group labels).
__attribute__((format(printf, 1, 2))) std::string strf(const char* f, ...) {
  va_list ap, ap2;
  va_start(ap, f);
  va_copy(ap2, ap);
  const int n = std::vsnprintf(nullptr, 0, f, ap);
  va_end(ap);
  std::string out(n > 0 ? static_cast<size_t>(n) : 0, '\0');
  if (n > 0) std::vsnprintf(out.data(), out.size() + 1, f, ap2);
  va_end(ap2);
  return out;
}

std::string fmt(const char* f, double v) {
  return strf(f, v);
}

std::string df_text(double df) {
  if (std::fabs(df - std::round(df)) < 1e-9) return fmt("%.0f", df);
  return fmt("%.2f", df);
}

// Statistics (t, F, q, g, H) from 1e6 on are printed in scientific notation.
constexpr double kScientificFrom = 1e6;

// 10^log10_v in scientific notation with `decimals` decimals, for a positive value beyond the
// range of a double (an F of 6.00e+400).
std::string pow10_text(double log10_v, int decimals) {
  double e = std::floor(log10_v);
  double m = std::pow(10.0, log10_v - e);
  if (std::stod(strf("%.*f", decimals, m)) >= 10) {  // 9.999… rounds up to 10.00
    m /= 10;
    e += 1;
  }
  return strf("%.*fe+%.0f", decimals, m, e);
}

}  // namespace

// A statistic with `decimals` decimals, from 1e6 on as d.dd…e+XX with as many decimals
// (-1.73e+200, not 201 digits); "n/a" when not finite.
std::string stat_text(double v, int decimals) {
  if (!std::isfinite(v)) return "n/a";
  return std::fabs(v) < kScientificFrom ? strf("%.*f", decimals, v) : strf("%.*e", decimals, v);
}

// An F statistic for text: finite, or beyond a double with its log10 known, or "n/a".
std::string f_text(double F, double log10_F, int decimals) {
  if (!std::isfinite(F) && std::isfinite(log10_F)) return pow10_text(log10_F, decimals);
  return stat_text(F, decimals);
}

namespace {

// A t statistic for an APA line: "= -1.73e+200", or a bound when it overflows a double (an SE
// of subnormal size).
std::string t_relation_text(double t) {
  if (std::isinf(t)) return t < 0 ? "< -1.8e+308" : "> 1.8e+308";
  return "= " + stat_text(t, 2);
}

std::string apa_f_log(double F, double log10_F, double df1, double df2, double p) {
  return "F(" + df_text(df1) + ", " + df_text(df2) + ") = " + f_text(F, log10_F, 2) + ", " +
         apa_p(p);
}

std::string apa_anova_log(const Anova& a, double log10_F) {
  if (!a.defined) return "undefined (no variation within groups)";
  return apa_f_log(a.F, log10_F, a.df_between, a.df_within, a.p);
}

// A number or null (JSON has no NaN / infinity).
nlohmann::json json_num(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
}

std::string num_text(double v, const char* f = "%.4g") {
  return std::isfinite(v) ? fmt(f, v) : std::string("n/a");
}

}  // namespace

std::string apa_p(double p) {
  if (!std::isfinite(p)) return "p = n/a";
  if (p < 0.001) return "p < .001";
  if (p >= 0.9995) return "p > .999";
  std::string s = fmt("%.3f", p);  // "0.003"
  return "p = " + s.substr(1);
}

std::string apa_f(double F, double df1, double df2, double p) {
  return apa_f_log(F, std::numeric_limits<double>::quiet_NaN(), df1, df2, p);
}

std::string apa_anova(const Anova& a) {
  return apa_anova_log(a, a.log10_F);
}

std::string apa_spread_test(const Anova& a, double log10_F) {
  if (!a.defined)
    return "undefined (the absolute deviations from each group's centre do not vary within "
           "any group, as with groups of 2)";
  return apa_anova_log(a, log10_F);
}

std::string apa_t(double t, double df, double p) {
  return "t(" + df_text(df) + ") " + t_relation_text(t) + ", " + apa_p(p);
}

std::string format_p(double p) {
  if (!std::isfinite(p)) return "n/a";
  if (p_is_bound(p)) return "< 1e-300";
  return fmt("%.4g", p);
}

std::string format_p(double p, bool is_bound) {
  if (is_bound && std::isfinite(p) && !p_is_bound(p)) return "< " + fmt("%.4g", p);
  return format_p(p);
}

StatsSummary summarize(const GroupedData& data, const StatsOptions& options) {
  StatsSummary s;
  s.options = options;
  s.names = data.names;
  const Groups& g = data.values;
  for (const auto& x : g) {
    s.groups.push_back(describe(x, data.offset));
    ShapiroWilk sw;
    if (x.size() >= 3 && x.size() <= 5000) {
      sw = shapiro_wilk(x);
    } else {
      sw.defined = false;
      sw.W = sw.p = NAN;
    }
    s.shapiro.push_back(sw);
  }
  s.anova = oneway_anova(g);
  // The interval's root search (serial, ~0.1 s for 30 groups) runs beside the pairwise tests.
  std::future<FEffectCi> effect_ci;
  if (s.anova.defined)
    effect_ci = std::async(std::launch::async, f_effect_ci, s.anova.F, s.anova.df_between,
                           s.anova.df_within, 0.95);
  s.welch = welch_anova(g);
  s.pairwise = pairwise_t(g, options.welch_pairwise, options.df_mode);
  // Each group sorted once; every pair's rank-sum test merges two of them.
  Groups sorted = g;
  for (auto& x : sorted) std::stable_sort(x.begin(), x.end());
  s.mann_whitney.resize(s.pairwise.size());
  parallel_for(s.pairwise.size(), [&](size_t i) {
    s.mann_whitney[i] = mann_whitney_sorted(sorted[s.pairwise[i].a], sorted[s.pairwise[i].b]);
  });
  if (options.margins) {
    s.equivalence.resize(s.pairwise.size());
    parallel_for(s.pairwise.size(), [&](size_t i) {
      const auto& pr = s.pairwise[i];
      s.equivalence[i] = tost_welch(g[pr.a], g[pr.b], options.margins->first,
                                    options.margins->second, options.alpha, options.df_mode);
    });
  }
  if (options.post_hoc) {
    s.tukey = tukey_kramer(g);
    s.games_howell = games_howell(g);
  }
  s.levene = levene(g, LeveneCentre::Mean);
  s.brown_forsythe = levene(g, LeveneCentre::Median);
  // F beyond the range of a double: oneway_anova keeps log F and its p (Anova::log10_F).
  s.anova_log10_F = s.anova.log10_F;
  s.levene_log10_F = s.levene.log10_F;
  s.brown_forsythe_log10_F = s.brown_forsythe.log10_F;
  s.kruskal = kruskal_wallis(g);
  if (effect_ci.valid()) s.anova_effect_ci = effect_ci.get();
  return s;
}

nlohmann::json to_json(const StatsSummary& s) {
  using nlohmann::json;
  json j;
  json groups = json::array();
  for (size_t i = 0; i < s.groups.size(); ++i) {
    const auto& d = s.groups[i];
    groups.push_back(
        {{"name", s.names[i]},
         {"n", d.n},
         {"mean", json_num(d.mean)},
         {"sd", json_num(d.sd)},
         {"se", json_num(d.se)},
         {"median", json_num(d.median)},
         {"q1", json_num(d.q1)},
         {"q3", json_num(d.q3)},
         {"iqr", json_num(d.iqr)},
         {"min", json_num(d.min)},
         {"max", json_num(d.max)},
         {"ci_low", json_num(d.ci_low)},
         {"ci_high", json_num(d.ci_high)},
         {"shapiro_wilk", {{"W", json_num(s.shapiro[i].W)}, {"p", json_num(s.shapiro[i].p)}}}});
  }
  j["groups"] = groups;
  const auto& a = s.anova;
  j["anova"] = {{"df_between", a.df_between},
                {"df_within", a.df_within},
                {"F", json_num(a.F)},
                {"p", json_num(a.p)},
                {"eta_squared", json_num(a.eta_squared)},
                {"omega_squared", json_num(a.omega_squared)},
                {"ss_between", a.ss_between},
                {"ss_within", a.ss_within},
                {"ms_between", a.ms_between},
                {"ms_within", a.ms_within},
                {"p_is_bound", p_is_bound(a.p)},
                {"apa", apa_anova_log(a, s.anova_log10_F)}};
  if (std::isfinite(s.anova_log10_F)) j["anova"]["log10_F"] = s.anova_log10_F;
  if (const auto& c = s.anova_effect_ci; c.defined) {
    // One interval for η² and ω²: both estimate the population proportion of variance.
    j["anova"]["effect_size_ci"] = {
        {"level", c.level},
        {"lambda", {json_num(c.lambda_low), json_num(c.lambda_high)}},
        {"eta_squared", {json_num(c.pve_low), json_num(c.pve_high)}},
        {"omega_squared", {json_num(c.pve_low), json_num(c.pve_high)}},
        {"method",
         "noncentral F inverted in lambda (Steiger 2004); bound = lambda / (lambda + "
         "df_between + df_within + 1)"}};
  }
  const auto& w = s.welch;
  j["welch_anova"] = {{"df_between", w.df_between},
                      {"df_within", json_num(w.df_within)},
                      {"F", json_num(w.F)},
                      {"p", json_num(w.p)},
                      {"eta_squared", json_num(w.eta_squared)},
                      {"p_is_bound", p_is_bound(w.p)},
                      {"apa", w.defined ? apa_f(w.F, w.df_between, w.df_within, w.p)
                                        : std::string("undefined: a group has zero variance")}};
  json pw = json::array();
  for (size_t i = 0; i < s.pairwise.size(); ++i) {
    const auto& p = s.pairwise[i];
    const auto& t = p.test;
    const auto& e = p.effect;
    const auto& mw = s.mann_whitney[i];
    pw.push_back({{"a", s.names[p.a]},
                  {"b", s.names[p.b]},
                  {"t", json_num(t.t)},
                  {"df", json_num(t.df)},
                  {"df_exact", json_num(t.df_exact)},
                  {"welch", t.welch},
                  {"p", json_num(t.p)},
                  {"p_holm", json_num(p.p_holm)},
                  {"p_is_bound", p_is_bound(t.p)},
                  {"p_holm_is_bound", p.p_holm_is_bound},
                  {"p_bonferroni", json_num(p.p_bonferroni)},
                  {"p_bonferroni_is_bound", p.p_bonferroni_is_bound},
                  {"mean_diff", json_num(t.mean_diff)},
                  {"se", json_num(t.se)},
                  {"ci_low", json_num(t.ci_low)},
                  {"ci_high", json_num(t.ci_high)},
                  {"cohens_d", json_num(e.d)},
                  {"cohens_d_ci", {json_num(e.d_ci_low), json_num(e.d_ci_high)}},
                  {"hedges_g", json_num(e.g)},
                  {"hedges_g_ci", {json_num(e.g_ci_low), json_num(e.g_ci_high)}},
                  {"effect_ci_method", e.ci_method},
                  {"mann_whitney", {{"W", mw.W}, {"p", json_num(mw.p)}, {"exact", mw.exact}}},
                  {"apa", t.defined ? apa_t(t.t, t.df, t.p) : std::string("undefined")}});
  }
  if (!s.equivalence.empty())
    for (size_t i = 0; i < s.pairwise.size(); ++i) {
      const auto& q = s.equivalence[i];
      pw[i]["equivalence"] = {
          {"margins", {q.low, q.high}},    {"alpha", q.alpha},
          {"t_low", json_num(q.t_low)},    {"t_high", json_num(q.t_high)},
          {"df", json_num(q.df)},          {"p_low", json_num(q.p_low)},
          {"p_high", json_num(q.p_high)},  {"p", json_num(q.p)},
          {"p_is_bound", p_is_bound(q.p)}, {"ci", {json_num(q.ci_low), json_num(q.ci_high)}},
          {"ci_level", 1 - 2 * q.alpha},   {"verdict", q.verdict}};
    }
  j["pairwise"] = pw;
  j["df_mode"] = s.options.df_mode == DfMode::Floor ? "floor" : "exact";
  auto range_json = [&](const std::vector<RangeComparison>& v) {
    json arr = json::array();
    for (const auto& r : v)
      arr.push_back({{"a", s.names[r.a]},
                     {"b", s.names[r.b]},
                     {"mean_diff", json_num(r.mean_diff)},
                     {"q", json_num(r.q)},
                     {"df", json_num(r.df)},
                     {"p", json_num(r.p)},
                     {"p_is_bound", p_is_bound(r.p)},
                     {"ci_low", json_num(r.ci_low)},
                     {"ci_high", json_num(r.ci_high)}});
    return arr;
  };
  if (s.options.post_hoc) {
    j["tukey"] = range_json(s.tukey);
    j["games_howell"] = range_json(s.games_howell);
  }
  auto hv = [&](const Anova& h, double log10_F) {
    json r{{"F", json_num(h.F)}, {"df1", h.df_between}, {"df2", h.df_within}, {"p", json_num(h.p)}};
    if (std::isfinite(log10_F)) r["log10_F"] = log10_F;
    return r;
  };
  j["levene"] = hv(s.levene, s.levene_log10_F);
  j["brown_forsythe"] = hv(s.brown_forsythe, s.brown_forsythe_log10_F);
  j["kruskal_wallis"] = {{"H", json_num(s.kruskal.H)},
                         {"df", s.kruskal.df},
                         {"p", json_num(s.kruskal.p)},
                         {"tie_correction", s.kruskal.tie_correction}};
  return j;
}

std::string to_text(const StatsSummary& s) {
  std::ostringstream o;
  // Group labels come from the input: control characters (an escape sequence in a label would
  // recolour or retitle the terminal) are shown escaped, and a label longer than 60 characters
  // cut to its start and length (shown_text: three labels of 3 MB were printed whole on every
  // line that names them, 36 MB of text); labels that look the same cut are told apart by their
  // place in the descriptives ("#2"). The JSON keeps them whole.
  std::vector<std::string> names;
  for (const auto& n : s.names) names.push_back(shown_text(n));
  std::map<std::string, int> seen;
  for (const auto& n : names) ++seen[n];
  for (size_t i = 0; i < names.size(); ++i)
    if (seen[names[i]] > 1) names[i] += " #" + std::to_string(i + 1);
  auto pair_name = [&](int a, int b) { return names[a] + " - " + names[b]; };
  o << "Descriptives\n";
  {
    // Five significant digits, more when the values are large beside their spread (values near
    // 1e12 that differ by units printed mean, median and CI all as "1e+12"): enough digits that
    // a group's standard error shows in its mean; a group without spread (constant values, or
    // one value) shows its values as they read back. At most 17 digits (a double's).
    int digits = 5;
    for (const auto& d : s.groups) {
      const double big = std::max({std::fabs(d.min), std::fabs(d.max), std::fabs(d.mean)});
      if (d.se > 0 && std::isfinite(d.se) && std::isfinite(big) && big > 0)
        digits = std::max(digits, static_cast<int>(std::ceil(std::log10(big / d.se))) + 2);
      else
        for (double v : {d.mean, d.min, d.max}) digits = std::max(digits, shortest_digits(v));
    }
    digits = std::min(digits, 17);
    const int cw = std::max(12, digits + 7), ciw = cw - 2;  // sign, point, "e+12"
    o << strf("  %-14s %5s %*s %*s %*s %*s %*s %*s %*s\n", "group", "n", cw, "mean", cw, "sd", cw,
              "se", cw, "median", cw, "min", cw, "max", 2 * ciw + 5, "95% CI of mean");
    for (size_t i = 0; i < s.groups.size(); ++i) {
      const auto& d = s.groups[i];
      o << strf("  %-*s %5d %*.*g %*.5g %*.5g %*.*g %*.*g %*.*g   [%*.*g, %*.*g]\n",
                printf_width(names[i], 14), names[i].c_str(), d.n, cw, digits, d.mean, cw, d.sd, cw,
                d.se, cw, digits, d.median, cw, digits, d.min, cw, digits, d.max, ciw, digits,
                d.ci_low, ciw, digits, d.ci_high);
    }
  }
  const auto& a = s.anova;
  o << "\nOne-way ANOVA\n";
  o << strf("  %-10s %8s %14s %14s %10s %10s\n", "source", "df", "SS", "MS", "F", "p");
  o << strf(
      "  %-10s %8s %14.6g %14.6g %10s %10s\n", "between", df_text(a.df_between).c_str(),
      a.ss_between, a.ms_between,
      (std::isfinite(s.anova_log10_F) ? pow10_text(s.anova_log10_F, 3) : num_text(a.F)).c_str(),
      format_p(a.p).c_str());
  o << strf("  %-10s %8s %14.6g %14.6g\n", "within", df_text(a.df_within).c_str(), a.ss_within,
            a.ms_within);
  o << "  " << apa_f_log(a.F, s.anova_log10_F, a.df_between, a.df_within, a.p)
    << ", eta^2 = " << num_text(a.eta_squared, "%.3f")
    << ", omega^2 = " << num_text(a.omega_squared, "%.3f") << "\n";
  if (const auto& c = s.anova_effect_ci; c.defined)
    o << "  95% CI of the population eta^2 (= omega^2), noncentral F: ["
      << num_text(c.pve_low, "%.3f") << ", " << num_text(c.pve_high, "%.3f") << "] (lambda ["
      << num_text(c.lambda_low, "%.4g") << ", " << num_text(c.lambda_high, "%.4g") << "])\n";
  const auto& w = s.welch;
  o << "\nWelch ANOVA\n  ";
  if (w.defined)
    o << apa_f(w.F, w.df_between, w.df_within, w.p)
      << ", eta^2 = " << num_text(w.eta_squared, "%.3f") << "\n";
  else
    o << "undefined: a group has zero variance\n";
  o << "\nPairwise " << (s.options.welch_pairwise ? "Welch" : "Student") << " t-tests (df "
    << (s.options.df_mode == DfMode::Floor ? "floored" : "exact") << ", Holm and Bonferroni)\n";
  o << strf("  %-22s %10s %9s %8s %10s %10s %10s %9s\n", "pair", "mean diff", "t", "df", "p",
            "p Holm", "p Bonf.", "Hedges g");
  for (const auto& p : s.pairwise)
    o << strf("  %-*s %10.4g %9s %8s %10s %10s %10s %9s\n", printf_width(pair_name(p.a, p.b), 22),
              pair_name(p.a, p.b).c_str(), p.test.mean_diff,
              (std::isinf(p.test.t) ? std::string(p.test.t < 0 ? "< -1.8e+308" : "> 1.8e+308")
                                    : stat_text(p.test.t, 3))
                  .c_str(),
              num_text(p.test.df, "%.2f").c_str(), format_p(p.test.p).c_str(),
              format_p(p.p_holm, p.p_holm_is_bound).c_str(),
              format_p(p.p_bonferroni, p.p_bonferroni_is_bound).c_str(),
              stat_text(p.effect.g, 3).c_str());
  for (const auto& p : s.pairwise)
    o << "  " << names[p.a] << " vs " << names[p.b] << ": "
      << (p.test.defined ? apa_t(p.test.t, p.test.df, p.test.p) : std::string("undefined"))
      << ", g = " << stat_text(p.effect.g, 2) << " [" << stat_text(p.effect.g_ci_low, 2) << ", "
      << stat_text(p.effect.g_ci_high, 2) << "]\n";
  if (!s.equivalence.empty()) {
    const auto& q0 = s.equivalence.front();
    o << "\nEquivalence (TOST on Welch's t, margins [" << num_text(q0.low) << ", "
      << num_text(q0.high) << "], alpha = " << num_text(q0.alpha) << ")\n";
    o << strf("  %-22s %10s %10s %25s  %s\n", "pair", "mean diff", "p TOST",
              (num_text(100 * (1 - 2 * q0.alpha), "%.0f") + "% CI").c_str(), "verdict");
    for (size_t i = 0; i < s.pairwise.size(); ++i) {
      const auto& q = s.equivalence[i];
      const std::string pair = pair_name(s.pairwise[i].a, s.pairwise[i].b);
      o << strf("  %-*s %10.4g %10s   [%10s, %10s]  %s\n", printf_width(pair, 22), pair.c_str(),
                q.mean_diff, format_p(q.p).c_str(), num_text(q.ci_low).c_str(),
                num_text(q.ci_high).c_str(), q.verdict.c_str());
    }
  }
  auto range_table = [&](const char* title, const std::vector<RangeComparison>& v) {
    o << "\n" << title << "\n";
    o << strf("  %-22s %10s %9s %8s %10s %25s\n", "pair", "mean diff", "q", "df", "p",
              "95% simultaneous CI");
    for (const auto& r : v)
      o << strf("  %-*s %10.4g %9s %8s %10s   [%10s, %10s]\n",
                printf_width(pair_name(r.a, r.b), 22), pair_name(r.a, r.b).c_str(), r.mean_diff,
                stat_text(r.q, 3).c_str(), num_text(r.df, "%.2f").c_str(), format_p(r.p).c_str(),
                num_text(r.ci_low).c_str(), num_text(r.ci_high).c_str());
  };
  if (s.options.post_hoc) {
    range_table("Tukey-Kramer HSD", s.tukey);
    range_table("Games-Howell", s.games_howell);
  }
  o << "\nAssumptions\n";
  o << "  Levene (mean):           " << apa_spread_test(s.levene, s.levene_log10_F) << "\n";
  o << "  Brown-Forsythe (median): " << apa_spread_test(s.brown_forsythe, s.brown_forsythe_log10_F)
    << "\n";
  for (size_t i = 0; i < s.shapiro.size(); ++i)
    o << "  Shapiro-Wilk " << names[i] << ": "
      << (s.shapiro[i].defined
              ? "W = " + num_text(s.shapiro[i].W, "%.4f") + ", " + apa_p(s.shapiro[i].p)
              : std::string("n/a (fewer than 3 values or all equal)"))
      << "\n";
  o << "\nNonparametric\n  Kruskal-Wallis: H(" << df_text(s.kruskal.df)
    << ") = " << num_text(s.kruskal.H, "%.2f") << ", " << apa_p(s.kruskal.p) << "\n";
  for (size_t i = 0; i < s.pairwise.size(); ++i) {
    const auto& m = s.mann_whitney[i];
    o << "  Mann-Whitney " << names[s.pairwise[i].a] << " vs " << names[s.pairwise[i].b]
      << ": W = " << num_text(m.W, "%.1f") << ", " << apa_p(m.p)
      << (m.exact ? " (exact)" : " (normal approx., continuity and tie corrected)") << "\n";
  }
  return o.str();
}

}  // namespace palplab::analysis
