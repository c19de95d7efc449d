#include "analysis/summary.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <future>
#include <sstream>

#include "analysis/distributions.hpp"
#include "analysis/parallel.hpp"

namespace palplab::analysis {

namespace {

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

std::string df_text(double df) {
  if (std::fabs(df - std::round(df)) < 1e-9) return fmt("%.0f", df);
  return fmt("%.2f", df);
}

// A number or null (JSON has no NaN / infinity).
nlohmann::json num(double v) {
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
  return "F(" + df_text(df1) + ", " + df_text(df2) + ") = " + num_text(F, "%.2f") + ", " + apa_p(p);
}

std::string apa_anova(const Anova& a) {
  if (!a.defined) return "undefined (no variation within groups)";
  return apa_f(a.F, a.df_between, a.df_within, a.p);
}

std::string apa_t(double t, double df, double p) {
  return "t(" + df_text(df) + ") = " + num_text(t, "%.2f") + ", " + apa_p(p);
}

std::string format_p(double p) {
  if (!std::isfinite(p)) return "n/a";
  if (p_is_bound(p)) return "< 1e-300";
  return fmt("%.4g", p);
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
    groups.push_back({{"name", s.names[i]},
                      {"n", d.n},
                      {"mean", num(d.mean)},
                      {"sd", num(d.sd)},
                      {"se", num(d.se)},
                      {"median", num(d.median)},
                      {"q1", num(d.q1)},
                      {"q3", num(d.q3)},
                      {"iqr", num(d.iqr)},
                      {"min", num(d.min)},
                      {"max", num(d.max)},
                      {"ci_low", num(d.ci_low)},
                      {"ci_high", num(d.ci_high)},
                      {"shapiro_wilk", {{"W", num(s.shapiro[i].W)}, {"p", num(s.shapiro[i].p)}}}});
  }
  j["groups"] = groups;
  const auto& a = s.anova;
  j["anova"] = {{"df_between", a.df_between},
                {"df_within", a.df_within},
                {"F", num(a.F)},
                {"p", num(a.p)},
                {"eta_squared", num(a.eta_squared)},
                {"omega_squared", num(a.omega_squared)},
                {"ss_between", a.ss_between},
                {"ss_within", a.ss_within},
                {"ms_between", a.ms_between},
                {"ms_within", a.ms_within},
                {"p_is_bound", p_is_bound(a.p)},
                {"apa", apa_anova(a)}};
  if (const auto& c = s.anova_effect_ci; c.defined) {
    // One interval for η² and ω²: both estimate the population proportion of variance.
    j["anova"]["effect_size_ci"] = {
        {"level", c.level},
        {"lambda", {num(c.lambda_low), num(c.lambda_high)}},
        {"eta_squared", {num(c.pve_low), num(c.pve_high)}},
        {"omega_squared", {num(c.pve_low), num(c.pve_high)}},
        {"method",
         "noncentral F inverted in lambda (Steiger 2004); bound = lambda / (lambda + "
         "df_between + df_within + 1)"}};
  }
  const auto& w = s.welch;
  j["welch_anova"] = {{"df_between", w.df_between},
                      {"df_within", num(w.df_within)},
                      {"F", num(w.F)},
                      {"p", num(w.p)},
                      {"eta_squared", num(w.eta_squared)},
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
                  {"t", num(t.t)},
                  {"df", num(t.df)},
                  {"df_exact", num(t.df_exact)},
                  {"welch", t.welch},
                  {"p", num(t.p)},
                  {"p_holm", num(p.p_holm)},
                  {"p_is_bound", p_is_bound(t.p)},
                  {"p_bonferroni", num(p.p_bonferroni)},
                  {"mean_diff", num(t.mean_diff)},
                  {"se", num(t.se)},
                  {"ci_low", num(t.ci_low)},
                  {"ci_high", num(t.ci_high)},
                  {"cohens_d", num(e.d)},
                  {"cohens_d_ci", {num(e.d_ci_low), num(e.d_ci_high)}},
                  {"hedges_g", num(e.g)},
                  {"hedges_g_ci", {num(e.g_ci_low), num(e.g_ci_high)}},
                  {"effect_ci_method", e.ci_method},
                  {"mann_whitney", {{"W", mw.W}, {"p", num(mw.p)}, {"exact", mw.exact}}},
                  {"apa", t.defined ? apa_t(t.t, t.df, t.p) : std::string("undefined")}});
  }
  if (!s.equivalence.empty())
    for (size_t i = 0; i < s.pairwise.size(); ++i) {
      const auto& q = s.equivalence[i];
      pw[i]["equivalence"] = {{"margins", {q.low, q.high}},
                              {"alpha", q.alpha},
                              {"t_low", num(q.t_low)},
                              {"t_high", num(q.t_high)},
                              {"df", num(q.df)},
                              {"p_low", num(q.p_low)},
                              {"p_high", num(q.p_high)},
                              {"p", num(q.p)},
                              {"ci", {num(q.ci_low), num(q.ci_high)}},
                              {"ci_level", 1 - 2 * q.alpha},
                              {"verdict", q.verdict}};
    }
  j["pairwise"] = pw;
  j["df_mode"] = s.options.df_mode == DfMode::Floor ? "floor" : "exact";
  auto range_json = [&](const std::vector<RangeComparison>& v) {
    json arr = json::array();
    for (const auto& r : v)
      arr.push_back({{"a", s.names[r.a]},
                     {"b", s.names[r.b]},
                     {"mean_diff", num(r.mean_diff)},
                     {"q", num(r.q)},
                     {"df", num(r.df)},
                     {"p", num(r.p)},
                     {"ci_low", num(r.ci_low)},
                     {"ci_high", num(r.ci_high)}});
    return arr;
  };
  if (s.options.post_hoc) {
    j["tukey"] = range_json(s.tukey);
    j["games_howell"] = range_json(s.games_howell);
  }
  auto hv = [&](const Anova& h) {
    return json{{"F", num(h.F)}, {"df1", h.df_between}, {"df2", h.df_within}, {"p", num(h.p)}};
  };
  j["levene"] = hv(s.levene);
  j["brown_forsythe"] = hv(s.brown_forsythe);
  j["kruskal_wallis"] = {{"H", num(s.kruskal.H)},
                         {"df", s.kruskal.df},
                         {"p", num(s.kruskal.p)},
                         {"tie_correction", s.kruskal.tie_correction}};
  return j;
}

std::string to_text(const StatsSummary& s) {
  std::ostringstream o;
  char b[512];
  o << "Descriptives\n";
  std::snprintf(b, sizeof b, "  %-14s %5s %12s %12s %12s %12s %12s %12s %25s\n", "group", "n",
                "mean", "sd", "se", "median", "min", "max", "95% CI of mean");
  o << b;
  for (size_t i = 0; i < s.groups.size(); ++i) {
    const auto& d = s.groups[i];
    std::snprintf(
        b, sizeof b, "  %-14s %5d %12.5g %12.5g %12.5g %12.5g %12.5g %12.5g   [%10.5g, %10.5g]\n",
        s.names[i].c_str(), d.n, d.mean, d.sd, d.se, d.median, d.min, d.max, d.ci_low, d.ci_high);
    o << b;
  }
  const auto& a = s.anova;
  o << "\nOne-way ANOVA\n";
  std::snprintf(b, sizeof b, "  %-10s %8s %14s %14s %10s %10s\n", "source", "df", "SS", "MS", "F",
                "p");
  o << b;
  std::snprintf(b, sizeof b, "  %-10s %8s %14.6g %14.6g %10s %10s\n", "between",
                df_text(a.df_between).c_str(), a.ss_between, a.ms_between, num_text(a.F).c_str(),
                format_p(a.p).c_str());
  o << b;
  std::snprintf(b, sizeof b, "  %-10s %8s %14.6g %14.6g\n", "within", df_text(a.df_within).c_str(),
                a.ss_within, a.ms_within);
  o << b;
  o << "  " << apa_f(a.F, a.df_between, a.df_within, a.p)
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
  std::snprintf(b, sizeof b, "  %-22s %10s %9s %8s %10s %10s %10s %9s\n", "pair", "mean diff", "t",
                "df", "p", "p Holm", "p Bonf.", "Hedges g");
  o << b;
  for (const auto& p : s.pairwise) {
    std::string pair = s.names[p.a] + " - " + s.names[p.b];
    std::snprintf(b, sizeof b, "  %-22s %10.4g %9s %8s %10s %10s %10s %9s\n", pair.c_str(),
                  p.test.mean_diff, num_text(p.test.t, "%.3f").c_str(),
                  num_text(p.test.df, "%.2f").c_str(), format_p(p.test.p).c_str(),
                  format_p(p.p_holm).c_str(), format_p(p.p_bonferroni).c_str(),
                  num_text(p.effect.g, "%.3f").c_str());
    o << b;
  }
  for (const auto& p : s.pairwise)
    o << "  " << s.names[p.a] << " vs " << s.names[p.b] << ": "
      << (p.test.defined ? apa_t(p.test.t, p.test.df, p.test.p) : std::string("undefined"))
      << ", g = " << num_text(p.effect.g, "%.2f") << " [" << num_text(p.effect.g_ci_low, "%.2f")
      << ", " << num_text(p.effect.g_ci_high, "%.2f") << "]\n";
  if (!s.equivalence.empty()) {
    const auto& q0 = s.equivalence.front();
    o << "\nEquivalence (TOST on Welch's t, margins [" << num_text(q0.low) << ", "
      << num_text(q0.high) << "], alpha = " << num_text(q0.alpha) << ")\n";
    std::snprintf(b, sizeof b, "  %-22s %10s %10s %25s  %s\n", "pair", "mean diff", "p TOST",
                  (num_text(100 * (1 - 2 * q0.alpha), "%.0f") + "% CI").c_str(), "verdict");
    o << b;
    for (size_t i = 0; i < s.pairwise.size(); ++i) {
      const auto& q = s.equivalence[i];
      std::string pair = s.names[s.pairwise[i].a] + " - " + s.names[s.pairwise[i].b];
      std::snprintf(b, sizeof b, "  %-22s %10.4g %10s   [%10s, %10s]  %s\n", pair.c_str(),
                    q.mean_diff, format_p(q.p).c_str(), num_text(q.ci_low).c_str(),
                    num_text(q.ci_high).c_str(), q.verdict.c_str());
      o << b;
    }
  }
  auto range_table = [&](const char* title, const std::vector<RangeComparison>& v) {
    o << "\n" << title << "\n";
    std::snprintf(b, sizeof b, "  %-22s %10s %9s %8s %10s %25s\n", "pair", "mean diff", "q", "df",
                  "p", "95% simultaneous CI");
    o << b;
    for (const auto& r : v) {
      std::string pair = s.names[r.a] + " - " + s.names[r.b];
      std::snprintf(b, sizeof b, "  %-22s %10.4g %9s %8s %10s   [%10s, %10s]\n", pair.c_str(),
                    r.mean_diff, num_text(r.q, "%.3f").c_str(), num_text(r.df, "%.2f").c_str(),
                    format_p(r.p).c_str(), num_text(r.ci_low).c_str(), num_text(r.ci_high).c_str());
      o << b;
    }
  };
  if (s.options.post_hoc) {
    range_table("Tukey-Kramer HSD", s.tukey);
    range_table("Games-Howell", s.games_howell);
  }
  o << "\nAssumptions\n";
  o << "  Levene (mean):           " << apa_anova(s.levene) << "\n";
  o << "  Brown-Forsythe (median): " << apa_anova(s.brown_forsythe) << "\n";
  for (size_t i = 0; i < s.shapiro.size(); ++i)
    o << "  Shapiro-Wilk " << s.names[i] << ": "
      << (s.shapiro[i].defined
              ? "W = " + num_text(s.shapiro[i].W, "%.4f") + ", " + apa_p(s.shapiro[i].p)
              : std::string("n/a (fewer than 3 values or all equal)"))
      << "\n";
  o << "\nNonparametric\n  Kruskal-Wallis: H(" << df_text(s.kruskal.df)
    << ") = " << num_text(s.kruskal.H, "%.2f") << ", " << apa_p(s.kruskal.p) << "\n";
  for (size_t i = 0; i < s.pairwise.size(); ++i) {
    const auto& m = s.mann_whitney[i];
    o << "  Mann-Whitney " << s.names[s.pairwise[i].a] << " vs " << s.names[s.pairwise[i].b]
      << ": W = " << num_text(m.W, "%.1f") << ", " << apa_p(m.p)
      << (m.exact ? " (exact)" : " (normal approx., continuity and tie corrected)") << "\n";
  }
  return o.str();
}

}  // namespace palplab::analysis
