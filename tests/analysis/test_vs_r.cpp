// Every statistic of the one-way summary against R 4.2.2 (tests/data/r: fixtures made by
// make_fixtures.R, reference values by make_reference.R, committed as reference.csv).
// Tolerances: 1e-10 relative on t, F, df, p, means, SDs, effect sizes, W, H (R is that
// accurate there); Tukey / Games–Howell p against R's ptukey at 5e-6 absolute (R's own
// accuracy, see tests/data/studentized-range/README.md; ours is checked against mpmath at
// 1e-11), Tukey intervals at 1e-4 relative (R's qtukey is accurate to ~4 decimals), the
// noncentral-t interval of d at 1e-8 relative (R's pt(ncp) ~1e-12 absolute, inverted).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <string>

#include "analysis/csv.hpp"
#include "analysis/distributions.hpp"
#include "analysis/grouped.hpp"
#include "analysis/summary.hpp"

using namespace palplab::analysis;

namespace {

const std::string kDir = std::string(PALPLAB_SOURCE_DIR) + "/tests/data/r/";

struct Fixture {
  std::string id, file, value;
  std::vector<WhereFilter> where;
};

std::map<std::string, double> compute(const Fixture& f) {
  CsvTable t = read_csv(kDir + f.file);
  GroupedData data = group_table(t, f.value, "group", f.where);
  StatsSummary s = summarize(data);
  auto floor = pairwise_t(data.values, true, DfMode::Floor);
  auto student = pairwise_t(data.values, false);
  std::map<std::string, double> o;
  const auto& nm = s.names;
  for (size_t i = 0; i < nm.size(); ++i) {
    o["n." + nm[i]] = s.groups[i].n;
    o["mean." + nm[i]] = s.groups[i].mean;
    o["sd." + nm[i]] = s.groups[i].sd;
    o["q1." + nm[i]] = s.groups[i].q1;
    o["median." + nm[i]] = s.groups[i].median;
    o["q3." + nm[i]] = s.groups[i].q3;
    o["ci." + nm[i] + ".lo"] = s.groups[i].ci_low;
    o["ci." + nm[i] + ".hi"] = s.groups[i].ci_high;
    if (s.shapiro[i].defined) {
      o["sw." + nm[i] + ".W"] = s.shapiro[i].W;
      o["sw." + nm[i] + ".p"] = s.shapiro[i].p;
    }
  }
  o["anova.F"] = s.anova.F;
  o["anova.p"] = s.anova.p;
  o["anova.df1"] = s.anova.df_between;
  o["anova.df2"] = s.anova.df_within;
  o["anova.eta2"] = s.anova.eta_squared;
  o["anova.omega2"] = s.anova.omega_squared;
  if (s.welch.defined) {
    o["welch.F"] = s.welch.F;
    o["welch.df2"] = s.welch.df_within;
    o["welch.p"] = s.welch.p;
  }
  o["levene.F"] = s.levene.F;
  o["levene.p"] = s.levene.p;
  o["bf.F"] = s.brown_forsythe.F;
  o["bf.p"] = s.brown_forsythe.p;
  o["kw.H"] = s.kruskal.H;
  o["kw.p"] = s.kruskal.p;
  for (size_t i = 0; i < s.pairwise.size(); ++i) {
    const auto& p = s.pairwise[i];
    std::string key = nm[p.a] + "." + nm[p.b];
    o["student." + key + ".t"] = student[i].test.t;
    o["student." + key + ".p"] = student[i].test.p;
    if (p.test.defined) {
      o["welch." + key + ".t"] = p.test.t;
      o["welch." + key + ".df"] = p.test.df;
      o["welch." + key + ".p"] = p.test.p;
      o["welch." + key + ".lo"] = p.test.ci_low;
      o["welch." + key + ".hi"] = p.test.ci_high;
      o["floor." + key + ".df"] = floor[i].test.df;
      o["floor." + key + ".p"] = floor[i].test.p;
      o["holm." + key] = p.p_holm;
      o["bonf." + key] = p.p_bonferroni;
      const auto& gh = s.games_howell[i];
      o["gh." + key + ".q"] = gh.q;
      o["gh." + key + ".df"] = gh.df;
      o["gh." + key + ".p"] = gh.p;
    }
    const auto& tk = s.tukey[i];
    o["tukey." + key + ".diff"] = tk.mean_diff;
    o["tukey." + key + ".p"] = tk.p;
    o["tukey." + key + ".lwr"] = tk.ci_low;
    o["tukey." + key + ".upr"] = tk.ci_high;
    // reference.csv holds the Student (pooled) interval of d; the pairwise table's is the
    // Welch-consistent one (equivalence.csv, TEST(VsR, EquivalenceAndWelchEffectSize)).
    EffectSize student = cohens_d(data.values[p.a], data.values[p.b]);
    if (student.defined) {
      o["d." + key] = student.d;
      o["g." + key] = student.g;
      o["d." + key + ".lo"] = student.d_ci_low;
      o["d." + key + ".hi"] = student.d_ci_high;
    }
    const auto& mw = s.mann_whitney[i];
    o["mw." + key + ".W"] = mw.W;
    o["mw." + key + ".p"] = mw.p;
    o["mw." + key + ".exact"] = mw.exact ? 1 : 0;
  }
  return o;
}

bool starts(const std::string& s, const char* p) {
  return s.rfind(p, 0) == 0;
}
bool ends(const std::string& s, const char* p) {
  return s.ends_with(p);
}

}  // namespace

TEST(VersusR, AllFixtures) {
  CsvTable ref = read_csv(kDir + "reference.csv");
  std::vector<Fixture> fixtures = {
      {"unequal", "unequal.csv", "force", {}},
      {"unequal_post", "unequal.csv", "force", {{"phase", "post"}}},
      {"ties", "ties.csv", "score", {}},
      {"n2", "n2.csv", "value", {}},
      {"constant", "constant.csv", "value", {}},
      {"offset_two", "offset_two.csv", "value", {}},
      {"large", "large.csv", "value", {}},
  };
  std::map<std::string, std::map<std::string, double>> ours;
  for (const auto& f : fixtures) ours[f.id] = compute(f);
  std::map<std::string, double> worst;  // per tolerance class
  int compared = 0, skipped = 0;
  for (size_t r = 0; r < ref.rows.size(); ++r) {
    const std::string& id = ref.rows[r][0];
    const std::string& key = ref.rows[r][1];
    double expect = std::stod(ref.rows[r][2]);
    ASSERT_TRUE(ours.count(id)) << id;
    auto it = ours[id].find(key);
    ASSERT_NE(it, ours[id].end()) << id << " " << key << " not computed";
    double got = it->second;
    if (std::isnan(expect)) {
      // R's ptukey is NaN for df < 2 (Games–Howell with n = 2); ours is checked there against
      // the k = 2 closed form in test_studentized_range.cpp.
      ++skipped;
      continue;
    }
    const bool degenerate_levene = (starts(key, "levene.") || starts(key, "bf.")) &&
                                   std::isinf(ours[id][key.substr(0, key.find('.')) + ".F"]);
    if (degenerate_levene && (std::fabs(expect) > 1e15 || expect < 1e-40)) {
      // Levene / Brown–Forsythe with n = 2 per group: both absolute deviations of a group are
      // equal, the within variance is 0 and F is infinite; R returns a rounding artefact
      // (~1e32). palplab reports F as undefined (null) instead of a meaningless number.
      ++skipped;
      continue;
    }
    std::string cls;
    double tol;
    if ((starts(key, "tukey.") || starts(key, "gh.")) && ends(key, ".p")) {
      cls = "studentized range p vs ptukey (abs)";
      tol = 5e-6;
    } else if (starts(key, "tukey.") && (ends(key, ".lwr") || ends(key, ".upr"))) {
      cls = "Tukey interval vs qtukey (rel)";
      tol = 1e-4 * std::fabs(expect);
    } else if (starts(key, "d.") && (ends(key, ".lo") || ends(key, ".hi"))) {
      cls = "d interval, noncentral t (rel)";
      tol = 1e-8 * std::fabs(expect);
    } else {
      cls = "t, F, df, p and the rest (rel)";
      tol = 1e-10 * std::fabs(expect) + 1e-15;
    }
    double err = std::fabs(got - expect);
    double shown = cls.ends_with("(abs)") || expect == 0 ? err : err / std::fabs(expect);
    worst[cls] = std::max(worst[cls], shown);
    EXPECT_LE(err, tol) << id << " " << key << ": palplab " << got << ", R " << expect;
    ++compared;
  }
  std::printf("[ R        ] %d values compared, %d skipped (R undefined or degenerate)\n", compared,
              skipped);
  for (const auto& [cls, w] : worst)
    std::printf("[ R        ]   max error %-40s %.2e\n", cls.c_str(), w);
  EXPECT_GT(compared, 600);
}

// F upper tails (and two-sided t p-values, d1 = 1) against R's pf on a grid with far tails and
// denominator df up to 1e6 (tests/data/r/pf_grid.csv, make_pf_grid.R): 1e-10 relative.
TEST(VersusR, FUpperTailGrid) {
  CsvTable g = read_csv(kDir + "pf_grid.csv");
  double worst = 0;
  for (size_t r = 0; r < g.rows.size(); ++r) {
    double f = std::stod(g.rows[r][0]), d1 = std::stod(g.rows[r][1]), d2 = std::stod(g.rows[r][2]);
    double expect = std::stod(g.rows[r][3]);
    double got = f_upper_p(f, d1, d2);
    EXPECT_LE(std::fabs(got - expect), 1e-10 * expect)
        << "F=" << f << " d1=" << d1 << " d2=" << d2 << ": palplab " << got << ", R " << expect;
    worst = std::max(worst, std::fabs(got - expect) / expect);
    if (d1 == 1) {
      EXPECT_LE(std::fabs(t_two_sided_p(-std::sqrt(f), d2) - expect), 1e-10 * expect);
    }
  }
  std::printf("[ R        ] F upper tail, %zu grid points: max relative error %.2e\n",
              g.rows.size(), worst);
}

// The noncentral-F interval of the ANOVA's η² / ω² (population proportion of variance) against
// base R (tests/data/r/make_effect_ci.R -> effect_ci.csv: pf(ncp =) inverted by uniroot).
// R's pnbeta is accurate to its errmax 1e-9 absolute; divided by dCDF/dλ (~1e-2) that allows
// ~1e-7 in λ, hence 1e-6 relative (1e-7 absolute near a bound of 0) on λ and on λ/(λ + n).
TEST(VsR, AnovaEffectSizeCi) {
  CsvTable ref = read_csv(kDir + "effect_ci.csv");
  std::map<std::string, std::map<std::string, double>> r;
  for (const auto& row : ref.rows) r[row[0]][row[1]] = std::strtod(row[2].c_str(), nullptr);
  int compared = 0;
  for (const Fixture& f :
       {Fixture{"unequal", "unequal.csv", "force", {}},
        Fixture{"unequal_post", "unequal.csv", "force", {{"phase", "post"}}},
        Fixture{"ties", "ties.csv", "score", {}}, Fixture{"large", "large.csv", "value", {}},
        Fixture{"close", "close.csv", "value", {}}, Fixture{"n2", "n2.csv", "value", {}}}) {
    CsvTable t = read_csv(kDir + f.file);
    StatsSummary s = summarize(group_table(t, f.value, "group", f.where));
    const auto& e = r.at(f.id);
    ASSERT_NEAR(s.anova.F, e.at("F"), 1e-10 * e.at("F")) << f.id;
    ASSERT_TRUE(s.anova_effect_ci.defined) << f.id;
    auto near = [&](double got, const std::string& key) {
      const double want = e.at(key);
      EXPECT_NEAR(got, want, 1e-6 * want + 1e-7) << f.id << " " << key;
      ++compared;
    };
    for (const auto& [level, tag] :
         {std::pair{0.95, std::string("")}, std::pair{0.90, std::string("90")}}) {
      FEffectCi c = level == 0.95
                        ? s.anova_effect_ci
                        : f_effect_ci(s.anova.F, s.anova.df_between, s.anova.df_within, level);
      near(c.lambda_low, "lambda" + tag + ".lo");
      near(c.lambda_high, "lambda" + tag + ".hi");
      near(c.pve_low, "pve" + tag + ".lo");
      near(c.pve_high, "pve" + tag + ".hi");
      // The interval contains the (less biased) point estimate ω² whenever ω² > 0.
      if (s.anova.omega_squared > 0) {
        EXPECT_LE(c.pve_low, s.anova.omega_squared) << f.id;
        EXPECT_GE(c.pve_high, s.anova.omega_squared) << f.id;
      }
    }
  }
  EXPECT_EQ(compared, 6 * 8);
}

// The noncentral F CDF against R's pf(x, d1, d2, ncp) on 400 points (effect_ci.csv, fixture
// "grid"): 2e-9 absolute (R's pnbeta errmax is 1e-9).
TEST(VsR, NoncentralFGrid) {
  CsvTable ref = read_csv(kDir + "effect_ci.csv");
  int n = 0;
  double worst = 0;
  for (const auto& row : ref.rows) {
    if (row[0] != "grid") continue;
    double d1, d2, ncp, x;
    ASSERT_EQ(std::sscanf(row[1].c_str(), "cdf:%lf:%lf:%lf:%lf", &d1, &d2, &ncp, &x), 4) << row[1];
    ++n;
    const double want = std::strtod(row[2].c_str(), nullptr);  // may be subnormal
    const double got = noncentral_f_cdf(x, d1, d2, ncp);
    worst = std::max(worst, std::fabs(got - want));
    EXPECT_NEAR(got, want, 2e-9) << row[1];
  }
  EXPECT_EQ(n, 400);
  std::printf("[ R        ] noncentral F CDF, %d grid points: max abs difference %.2e\n", n, worst);
}

// Welch-consistent interval of d and TOST equivalence tests against base R
// (tests/data/r/make_equivalence.R -> equivalence.csv: t.test with mu and one-sided
// alternatives, pt with ncp inverted by uniroot). Margins ±7 % of the fixture's grand mean (the
// force Weber fraction, as the report's default for forces).
TEST(VsR, EquivalenceAndWelchEffectSize) {
  CsvTable ref = read_csv(std::string(PALPLAB_SOURCE_DIR) + "/tests/data/r/equivalence.csv");
  struct F {
    std::string id, file, value;
    std::vector<WhereFilter> where;
  };
  std::map<std::string, std::map<std::string, double>> ours;
  std::map<std::string, std::map<std::string, std::string>> verdicts;
  for (const F& f : {F{"unequal", "unequal.csv", "force", {}},
                     F{"unequal_post", "unequal.csv", "force", {{"phase", "post"}}},
                     F{"ties", "ties.csv", "score", {}}, F{"large", "large.csv", "value", {}},
                     F{"close", "close.csv", "value", {}}}) {
    CsvTable t = read_csv(std::string(PALPLAB_SOURCE_DIR) + "/tests/data/r/" + f.file);
    GroupedData data = group_table(t, f.value, "group", f.where);
    long double sum = 0;
    int n = 0;
    for (const auto& g : data.values)
      for (double v : g) {
        sum += v + static_cast<long double>(data.offset);
        ++n;
      }
    const double margin = 0.07 * static_cast<double>(sum / n);
    auto& o = ours[f.id];
    for (size_t a = 0; a < data.values.size(); ++a)
      for (size_t b = a + 1; b < data.values.size(); ++b) {
        const std::string key = data.names[a] + "." + data.names[b];
        TTest w = welch_t(data.values[a], data.values[b]);
        EffectSize e = cohens_d_welch(data.values[a], data.values[b], w);
        o["dw." + key + ".lo"] = e.d_ci_low;
        o["dw." + key + ".hi"] = e.d_ci_high;
        // Consistency: the interval excludes 0 exactly when Welch's p < .05.
        EXPECT_EQ(e.d_ci_low > 0 || e.d_ci_high < 0, w.p < 0.05) << f.id << " " << key;
        Equivalence q = tost_welch(data.values[a], data.values[b], -margin, margin);
        o["tost." + key + ".p_low"] = q.p_low;
        o["tost." + key + ".p_high"] = q.p_high;
        o["tost." + key + ".p"] = q.p;
        o["tost." + key + ".lo90"] = q.ci_low;
        o["tost." + key + ".hi90"] = q.ci_high;
        o["tost." + key + ".margin"] = margin;
        verdicts[f.id][key] = q.verdict;
        EXPECT_EQ(q.ci_low > -margin && q.ci_high < margin, q.p < 0.05) << f.id << " " << key;
      }
  }
  int compared = 0;
  double worst = 0;
  std::set<std::string> seen_verdicts;
  for (size_t r = 0; r < ref.rows.size(); ++r) {
    const std::string &id = ref.rows[r][0], &key = ref.rows[r][1], &val = ref.rows[r][2];
    ASSERT_TRUE(ours.count(id)) << id;
    if (key.ends_with(".verdict")) {
      std::string pair = key.substr(5, key.size() - 5 - 8);  // "tost." pair ".verdict"
      EXPECT_EQ(verdicts[id][pair], val) << id << " " << key;
      seen_verdicts.insert(val);
      continue;
    }
    auto it = ours[id].find(key);
    ASSERT_NE(it, ours[id].end()) << id << " " << key;
    double expect = std::stod(val), got = it->second;
    // uniroot's tol = 1e-14 on δ; R's pt with ncp (AS 243) is good to ~1e-12 near the centre.
    double tol = key.starts_with("dw.") ? 1e-8 : 1e-10;
    EXPECT_NEAR(got, expect, tol * std::fabs(expect) + 1e-14) << id << " " << key;
    worst = std::max(worst, std::fabs(got - expect) / std::max(std::fabs(expect), 1e-300));
    ++compared;
  }
  EXPECT_GE(compared, 40);
  // The fixtures are chosen so that all three verdicts occur.
  EXPECT_EQ(seen_verdicts.size(), 3u);
  std::printf("[ R        ] equivalence / Welch d interval: %d values, max rel error %.1e\n",
              compared, worst);
}
