// Linear mixed models (analysis/lmm.hpp) against lme4 1.1 + lmerTest 3.1 (reference.csv made by
// tests/data/lmm/make_reference.R on the committed fixtures sleepstudy.csv, study.csv and
// study_blocks.csv, with a
// tightened optimiser tolerance), plus analytic checks of the profiled deviance.
// Tolerances: fixed effects, SEs, t, variance components, theta, F and Sum Sq 1e-6 relative;
// log-likelihood, REML criterion/deviance, AIC, BIC 1e-8 absolute (values ~1e2..1e3); Satterthwaite
// df and p-values 2e-5 relative (both lmerTest and we differentiate numerically: lmerTest's df for
// sleepstudy is 17.0000052, ours 17.0000017); multi-df F denominator df 1e-4 (see below).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <string>

#include "analysis/csv.hpp"
#include "analysis/lmm.hpp"
#include "common/input_error.hpp"
#include "tests/analysis/support.hpp"

using namespace palplab::analysis;

namespace {

const std::string kDir = std::string(PALPLAB_SOURCE_DIR) + "/tests/data/lmm/";

struct Ref {
  std::map<std::string, double> v;  // "quantity|term" -> value
  bool has(const std::string& q, const std::string& t = "") const { return v.count(q + "|" + t); }
  double at(const std::string& q, const std::string& t = "") const { return v.at(q + "|" + t); }
};

std::map<std::string, Ref> load_reference() {
  CsvTable t = read_csv(kDir + "reference.csv");
  std::map<std::string, Ref> out;
  for (size_t r = 0; r < t.rows.size(); ++r)
    out[t.rows[r][0] + "|" + t.rows[r][1]].v[t.rows[r][2] + "|" + t.rows[r][3]] =
        parse_number(t, static_cast<int>(r), 4);
  return out;
}

struct Case {
  std::string name, file, formula;
};

void check_case(const Case& c, bool reml) {
  static const auto ref_all = load_reference();
  const std::string meth = reml ? "REML" : "ML";
  const Ref& ref = ref_all.at(c.name + "|" + meth);
  const std::string tag = c.name + " " + meth;
  CsvTable t = read_csv(kDir + c.file);
  LmmFit fit = fit_lmm(t, parse_lmm_formula(c.formula), {}, reml);
  int n_fixed = 0;
  for (const auto& fe : fit.fixed) {
    ASSERT_TRUE(ref.has("estimate", fe.name)) << tag << ": lme4 has no term " << fe.name;
    ++n_fixed;
    expect_rel(fe.estimate, ref.at("estimate", fe.name), 1e-6, tag + " estimate " + fe.name);
    expect_rel(fe.se, ref.at("se", fe.name), 1e-6, tag + " se " + fe.name);
    expect_rel(fe.t, ref.at("t", fe.name), 1e-6, tag + " t " + fe.name);
    expect_rel(fe.df, ref.at("df", fe.name), 2e-5, tag + " df " + fe.name);
    expect_rel(fe.p, ref.at("p", fe.name), 2e-5, tag + " p " + fe.name);
  }
  int ref_fixed = 0;
  for (const auto& [k, v] : ref.v) ref_fixed += k.rfind("estimate|", 0) == 0;
  EXPECT_EQ(n_fixed, ref_fixed) << tag;
  expect_rel(fit.sd_intercept, ref.at("sd_intercept"), 1e-6, tag + " sd_intercept");
  expect_rel(fit.sigma, ref.at("sigma"), 1e-6, tag + " sigma");
  if (ref.has("sd_slope")) {
    expect_rel(fit.sd_slope, ref.at("sd_slope"), 1e-6, tag + " sd_slope");
    expect_rel(fit.correlation, ref.at("correlation"), 1e-6, tag + " correlation");
  }
  for (size_t i = 0; i < fit.theta.size(); ++i)
    expect_rel(fit.theta[i], ref.at("theta", std::to_string(i)), 1e-6, tag + " theta");
  EXPECT_NEAR(fit.loglik, ref.at("loglik"), 1e-8) << tag;
  EXPECT_NEAR(fit.deviance, ref.at("deviance"), 1e-8) << tag;
  EXPECT_NEAR(fit.aic, ref.at("aic"), 1e-8) << tag;
  EXPECT_NEAR(fit.bic, ref.at("bic"), 1e-8) << tag;
  ASSERT_FALSE(fit.anova.empty());
  for (const auto& a : fit.anova) {
    ASSERT_TRUE(ref.has("F", a.term)) << tag << ": lmerTest has no term " << a.term;
    expect_rel(a.f, ref.at("F", a.term), 1e-6, tag + " F " + a.term);
    EXPECT_EQ(a.num_df, static_cast<int>(ref.at("NumDF", a.term))) << tag << " " << a.term;
    // A multi-df denominator df combines the df of q one-df contrasts and depends slightly on
    // the basis of the hypothesis (ours: sum-coded rows; lmerTest: its own type III L with the
    // same row space, same F to 1e-7): up to 1.9e-5 relative observed, hence 1e-4 there.
    expect_rel(a.den_df, ref.at("DenDF", a.term), a.num_df == 1 ? 2e-5 : 1e-4,
               tag + " DenDF " + a.term);
    expect_rel(a.p, ref.at("F_p", a.term), 2e-5, tag + " F p " + a.term);
    expect_rel(a.sum_sq, ref.at("SumSq", a.term), 1e-6, tag + " Sum Sq " + a.term);
  }
}

const Case kSleepSlope{"sleep_slope", "sleepstudy.csv", "Reaction ~ Days + (Days | Subject)"};
const Case kSleepInt{"sleep_int", "sleepstudy.csv", "Reaction ~ Days + (1 | Subject)"};
const Case kStudyInt{"study_int", "study.csv", "value ~ group * session + (1 | participant)"};
const Case kStudySlope{"study_slope", "study.csv",
                       "value ~ group * session + (1 + session | participant)"};

const Case kStudyBlocks{"study_blocks", "study_blocks.csv",
                        "value ~ group * block + (1 | participant)"};

}  // namespace

TEST(LmmVsLme4, SleepstudySlopeReml) {
  check_case(kSleepSlope, true);
}
TEST(LmmVsLme4, SleepstudySlopeMl) {
  check_case(kSleepSlope, false);
}
TEST(LmmVsLme4, SleepstudyInterceptReml) {
  check_case(kSleepInt, true);
}
TEST(LmmVsLme4, SleepstudyInterceptMl) {
  check_case(kSleepInt, false);
}
TEST(LmmVsLme4, StudyGroupBySessionReml) {
  check_case(kStudyInt, true);
}
TEST(LmmVsLme4, StudyGroupBySessionMl) {
  check_case(kStudyInt, false);
}
TEST(LmmVsLme4, StudyRandomSlopeReml) {
  check_case(kStudySlope, true);
}
TEST(LmmVsLme4, StudyRandomSlopeMl) {
  check_case(kStudySlope, false);
}
// Factor x factor (3 x 5): column order groupB:blockS2, groupC:blockS2, ... and an 8-df F.
TEST(LmmVsLme4, StudyFactorByFactorReml) {
  check_case(kStudyBlocks, true);
}
TEST(LmmVsLme4, StudyFactorByFactorMl) {
  check_case(kStudyBlocks, false);
}

// At theta = 0 the random effects vanish: the ML profiled deviance is the OLS one,
// n (1 + log(2 pi RSS / n)), and REML adds log|X'X| with n - p in place of n.
TEST(LmmDeviance, ThetaZeroIsOrdinaryLeastSquares) {
  LmmData d;
  const double xs[] = {0, 1, 2, 3, 4, 5, 6, 7};
  const double ys[] = {1.0, 2.1, 2.9, 4.2, 4.8, 6.3, 6.9, 8.1};
  for (int i = 0; i < 8; ++i) {
    d.y.push_back(ys[i]);
    d.x.push_back({1.0, xs[i]});
    d.z.push_back({1.0});
    d.g.push_back(i / 4);
  }
  d.n_groups = 2;
  // OLS by hand
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (int i = 0; i < 8; ++i) sx += xs[i], sy += ys[i], sxx += xs[i] * xs[i], sxy += xs[i] * ys[i];
  const double b1 = (8 * sxy - sx * sy) / (8 * sxx - sx * sx), b0 = (sy - b1 * sx) / 8;
  double rss = 0;
  for (int i = 0; i < 8; ++i) rss += std::pow(ys[i] - b0 - b1 * xs[i], 2);
  const double two_pi = 2 * std::numbers::pi;
  EXPECT_NEAR(lmm_profiled_deviance(d, {0.0}, false), 8 * (1 + std::log(two_pi * rss / 8)), 1e-12);
  const double logdet_xtx = std::log(8 * sxx - sx * sx);
  EXPECT_NEAR(lmm_profiled_deviance(d, {0.0}, true),
              logdet_xtx + 6 * (1 + std::log(two_pi * rss / 6)), 1e-12);
}

// With one observation per cell of a balanced one-way random model, the ML deviance at theta
// equals -2 log of the multivariate normal density with V = sigma^2 (I + theta^2 Z Z') at the
// profiled sigma and beta, computed here by brute force.
TEST(LmmDeviance, MatchesDirectGaussianLikelihood) {
  LmmData d;
  const double ys[] = {3.1, 2.4, 3.9, 5.0, 4.4, 5.6, 1.2, 1.9, 0.7};
  for (int i = 0; i < 9; ++i) {
    d.y.push_back(ys[i]);
    d.x.push_back({1.0});
    d.z.push_back({1.0});
    d.g.push_back(i / 3);
  }
  d.n_groups = 3;
  const double th = 0.8;
  // V/sigma^2 is block diagonal with blocks I + th^2 J (3 x 3); GLS mean is the grand mean here
  // (balanced), quadratic form and log det in closed form per block.
  const double a = th * th;
  double mean = 0;
  for (double y : ys) mean += y / 9;
  double quad = 0;
  for (int g = 0; g < 3; ++g) {
    double s = 0, ss = 0;
    for (int i = 0; i < 3; ++i) {
      double r = ys[3 * g + i] - mean;
      s += r;
      ss += r * r;
    }
    quad += ss - a / (1 + 3 * a) * s * s;  // r'(I + aJ)^-1 r
  }
  const double logdet = 3 * std::log(1 + 3 * a);
  const double s2 = quad / 9;
  const double dev = logdet + 9 * std::log(2 * std::numbers::pi * s2) + 9;
  EXPECT_NEAR(lmm_profiled_deviance(d, {th}, false), dev, 1e-12);
}

TEST(LmmFormula, ExpandsAndOrdersTermsAsR) {
  auto f = parse_lmm_formula("y ~ session * group + age + (1 + session | pid)");
  EXPECT_EQ(f.response, "y");
  ASSERT_EQ(f.terms.size(), 4u);
  EXPECT_EQ(f.terms[0], std::vector<std::string>{"session"});
  EXPECT_EQ(f.terms[1], std::vector<std::string>{"group"});
  EXPECT_EQ(f.terms[2], std::vector<std::string>{"age"});
  EXPECT_EQ(f.terms[3], (std::vector<std::string>{"session", "group"}));
  EXPECT_EQ(f.group, "pid");
  EXPECT_EQ(f.slope, "session");
  auto g = parse_lmm_formula("y ~ a + b + a:b + (x | g)");
  EXPECT_EQ(g.terms.size(), 3u);
  EXPECT_EQ(g.slope, "x");
}

TEST(LmmFormula, LocatedErrorsOutsideTheGrammar) {
  auto err = [](const std::string& f) {
    try {
      parse_lmm_formula(f);
    } catch (const palplab::InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(err("y ~ a + (1 | g) + (1 | h)").find("only one random-effects term"),
            std::string::npos);
  EXPECT_NE(err("y ~ a + (0 + x | g)").find("--formula"), std::string::npos);
  EXPECT_NE(err("y ~ a").find("random-effects term"), std::string::npos);
  EXPECT_NE(err("y ~ a:b + (1 | g)").find("lower-order"), std::string::npos);
  // At the interaction's first variable, and at the response used as a predictor (both said
  // character 1: review 2026-12-06, fourth).
  EXPECT_NE(err("y ~ group:session + (1 | g)").find("(use '*') (at character 5)"),
            std::string::npos)
      << err("y ~ group:session + (1 | g)");
  EXPECT_NE(err("y ~ x + (1 | g) + c:x").find("(use '*') (at character 19)"), std::string::npos)
      << err("y ~ x + (1 | g) + c:x");
  EXPECT_NE(err("y ~ a + y + (1 | g)").find("is also a predictor (at character 9)"),
            std::string::npos)
      << err("y ~ a + y + (1 | g)");
  EXPECT_NE(err("y ~ log(a) + (1 | g)").find("--formula"), std::string::npos);
  EXPECT_NE(err("y ~ a + (1 | g/h)").find("unexpected character '/'"), std::string::npos);
  EXPECT_NE(err("y a + (1|g)").find("'~'"), std::string::npos);
  EXPECT_NE(err("y ~ a + (1 | g").find("')'"), std::string::npos);
  // Positions count characters, not bytes, and a non-ASCII name is a name (a CSV column
  // "Größe"); a non-ASCII symbol between names is said whole (it was echoed as a lone byte of
  // its UTF-8 and located by bytes: 2026-12-06, noticed).
  const LmmFormula f = parse_lmm_formula("Größe ~ Tag + (1 | Proband)");
  EXPECT_EQ(f.response, "Größe");
  EXPECT_EQ(f.positions.at("Tag"), 8);
  EXPECT_EQ(f.positions.at("Proband"), 19);
  EXPECT_NE(err("Größe ~ Tag/2 + (1 | g)")
                .find("unexpected character '/' (supported: y ~ a * b "
                      "+ c:d + (1 | g) or (1 + x | g)) (at character 12)"),
            std::string::npos)
      << err("Größe ~ Tag/2 + (1 | g)");
  // Operator and space look-alikes pasted from a word processor are said as what they look like
  // (they were read as names: "a × b" said "expected '+' between terms", "a\u00A0+ b" looked
  // for a column "a\u00A0"; 2026-12-06, noticed).
  const std::string supported =
      "; supported: y ~ a * b + c:d + (1 | g) or (1 + x | g)) (at character ";
  for (const auto& [formula, said] : std::vector<std::pair<std::string, std::string>>{
           {"y ~ a × b + (1 | g)", "'×' (U+00D7, use '*' for an interaction" + supported + "7)"},
           {"y ~ a·b + (1 | g)", "'·' (U+00B7, use '*' for an interaction" + supported + "6)"},
           {"y ~ a − 1 + (1 | g)",
            "'−' (U+2212, a minus or dash: terms are only added ('+'; no '- 1')" + supported +
                "7)"},
           {"y ~ a – b + (1 | g)", "'–' (U+2013, a minus or dash"},
           {"y ~ a\u00A0+ b + (1 | g)",
            "'\u00A0' (U+00A0, a Unicode space: use an ordinary space" + supported + "6)"},
           {"y ～ a + (1 | g)", "'～' (U+FF5E, use the ASCII '~'" + supported + "3)"},
           {"y ~ a + (1 ｜ g)", "'｜' (U+FF5C, use the ASCII '|'"},
           {"y ~ “a” + (1 | g)",
            "'“' (U+201C, names are written without quotes" + supported + "5)"},
           {"y ~ a\u2009+ b + (1 | g)", "'\u2009' (U+2009, a Unicode space"},
           {"y ~ a＊b + (1 | g)", "'＊' (U+FF0A, use '*' for an interaction"},
           {"y ~ a ✕ b + (1 | g)", "'✕' (U+2715, use '*' for an interaction"},
           {"y ~ a\u200C + (1 | g)", "'\u200C' (U+200C, an invisible character"},
           {"y ~ a\u00AD + (1 | g)", "'\u00AD' (U+00AD, an invisible character"},
           {"y ~ a\u2060 + (1 | g)", "'\u2060' (U+2060, an invisible character"}}) {
    const std::string e = err(formula);
    EXPECT_NE(e.find("--formula: unexpected character " + said), std::string::npos) << e;
  }
  EXPECT_NE(err("y ~ a\xff + (1 | g)")
                .find("--formula: unexpected byte 0xFF (not UTF-8; supported: y ~ a * b + c:d + "
                      "(1 | g) or (1 + x | g)) (at character 6)"),
            std::string::npos)
      << err("y ~ a\xff + (1 | g)");
  // Letters beyond ASCII stay names (µ, accents, Greek, CJK, a superscript).
  const LmmFormula g = parse_lmm_formula("Fläche_m² ~ µ + Δt + 時間 + (1 | Proband)");
  EXPECT_EQ(g.response, "Fläche_m²");
  EXPECT_EQ(g.positions.at("時間"), 21);
}

// Non-ASCII names line up in the text tables (they were padded by bytes: "Größe" two columns
// off; review 2026-12-06, seventh): the sleepstudy with its columns renamed prints the same
// table shape as with ASCII names of the same length.
TEST(LmmFormula, NonAsciiNamesLineUpInTheTables) {
  CsvTable t = read_csv(kDir + "sleepstudy.csv");
  CsvTable u = t;
  u.header = {"Reaktionszeit_ä", "Tagé", "Proband_ö"};
  t.header = {"Reaktionszeit_a", "Tage", "Proband_o"};
  const auto text = [](const CsvTable& c, const std::string& f) {
    return to_text(fit_lmm(c, parse_lmm_formula(f), {}, true), f);
  };
  std::string a = text(t, "Reaktionszeit_a ~ Tage + (1 | Proband_o)");
  std::string b = text(u, "Reaktionszeit_ä ~ Tagé + (1 | Proband_ö)");
  for (const auto& [from, to] :
       std::vector<std::pair<std::string, std::string>>{{"ä", "a"}, {"é", "e"}, {"ö", "o"}})
    for (std::size_t at; (at = b.find(from)) != std::string::npos;) b.replace(at, from.size(), to);
  EXPECT_EQ(a, b);
}

// A formula's name that is no column of the CSV was located at the CSV's header line; it is the
// formula's mistake as often as the file's: said at the name, with the file's columns.
TEST(LmmFormula, UnknownColumnIsLocatedAtTheName) {
  const CsvTable t = read_csv(kDir + "sleepstudy.csv");
  try {
    fit_lmm(t, parse_lmm_formula("Reaction ~ Dayz + (1 | Subject)"), {}, true);
    FAIL();
  } catch (const palplab::InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "--formula: no column 'Dayz' in " + kDir +
                  "sleepstudy.csv (at character 12); its columns are: Reaction, Days, Subject");
  }
  // A name typed with a combining accent (NFD) never equals the column's precomposed letter
  // (NFC) that looks the same, and the other way round: said, as neither shows it.
  CsvTable u = t;
  u.header = {"Reaktion", "Tage", "Proband\u00F6"};  // Probandö, precomposed
  const auto message = [](const CsvTable& c, const std::string& f) {
    try {
      fit_lmm(c, parse_lmm_formula(f), {}, true);
    } catch (const palplab::InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  std::string m = message(u, "Reaktion ~ Tage + (1 | Probando\u0308)");
  EXPECT_NE(m.find("no column 'Probando\u0308' in " + kDir +
                   "sleepstudy.csv (at character 24); its columns are: Reaktion, Tage, "
                   "Proband\u00F6 ('Probando\u0308' is written with a combining accent (Unicode "
                   "NFD), which never equals a precomposed letter (NFC) that looks the same: type "
                   "the name again)"),
            std::string::npos)
      << m;
  u.header = {"Reaktion", "Tage", "Probando\u0308"};
  m = message(u, "Reaktion ~ Tage + (1 | Proband\u00F6)");
  EXPECT_NE(m.find("(the column 'Probando\u0308' is written with a combining accent"),
            std::string::npos)
      << m;
  // Not for a name that only happens to be non-ASCII (the hint named an unrelated column).
  m = message(u, "Reaktion ~ Tage + (1 | Zeit\u00E4)");
  EXPECT_EQ(m.find("combining accent"), std::string::npos) << m;
  // The same names in the same form fit.
  EXPECT_EQ(message(u, "Reaktion ~ Tage + (1 | Probando\u0308)"), "no error");
}

// A singular random-slope fit (no participant slope variation: theta[2] on its bound 0), the
// case that ran the Nelder–Mead search to its iteration cap (0.6 s) before the stall test.
// (1) Regression: the values the fit gave before that change (palplab at d8acd80, the search
// then ran to the cap), to 1e-8 relative — the change only stops the search earlier, and the
// twelve fits of tests/data/lmm and this one were bit-identical before/after.
// (2) lme4 1.1.31 (make_singular_reference.R -> singular_reference.txt): also singular; our
// criterion is at least as low (lme4 stops earlier in the flat direction, 3e-9 higher),
// fixed effects agree to 1e-10, theta[0] to 2e-5 (flat), sigma to 1e-5.
TEST(LmmSingular, UnchangedAndAsGoodAsLme4) {
  CsvTable t = read_csv(kDir + "singular.csv");
  const LmmFormula f = parse_lmm_formula("value ~ group * session + (1 + session | participant)");
  struct Before {
    bool reml;
    double theta0, theta1, sigma, crit;
    double beta[4], se[4], df[4];
  };
  const Before before[2] = {
      {true,
       6.090424537142776,
       -0.0838415811123154,
       0.06389441701352341,
       -82.69859132606682,
       {2.9900000000002542, -0.40000000000015945, -0.2966666666666703, 0.20000000000000212},
       {0.16120581892359817, 0.22797945545521192, 0.008533729132140287, 0.012068515476291185},
       {10.004506811374814, 10.004506811551536, 31.517019881950567, 31.51701988239321}},
      {false,
       5.676851972363297,
       -0.07814828945090671,
       0.06254912054243884,
       -102.28350984103523,
       {2.9900000000002, -0.4000000000002641, -0.2966666666666726, 0.2000000000000073},
       {0.14741490668444898, 0.20847616032910693, 0.008317980884075822, 0.011763401377820122},
       {12.007305792830913, 12.007305792656057, 35.90401631525923, 35.904016314972786}}};
  std::ifstream ref(kDir + "singular_reference.txt");
  for (const Before& b : before) {
    LmmFit fit = fit_lmm(t, f, {}, b.reml);
    auto rel = [](double got, double want) {
      return std::abs(got - want) / std::max(std::abs(want), 1e-300);
    };
    ASSERT_EQ(fit.theta.size(), 3u);
    EXPECT_EQ(fit.theta[2], 0.0);
    ASSERT_FALSE(fit.warnings.empty());
    EXPECT_EQ(fit.warnings[0].rfind("singular fit", 0), 0u);
    EXPECT_LE(rel(fit.theta[0], b.theta0), 1e-8);
    EXPECT_LE(rel(fit.theta[1], b.theta1), 1e-8);
    EXPECT_LE(rel(fit.sigma, b.sigma), 1e-8);
    EXPECT_LE(rel(fit.deviance, b.crit), 1e-8);
    for (int j = 0; j < 4; ++j) {
      EXPECT_LE(rel(fit.fixed[j].estimate, b.beta[j]), 1e-8) << j;
      EXPECT_LE(rel(fit.fixed[j].se, b.se[j]), 1e-8) << j;
      EXPECT_LE(rel(fit.fixed[j].df, b.df[j]), 1e-8) << j;
    }
    std::string method;
    double th[3], sigma, crit, beta[4];
    std::string singular;
    ASSERT_TRUE(ref >> method >> th[0] >> th[1] >> th[2] >> sigma >> crit >> beta[0] >> beta[1] >>
                beta[2] >> beta[3] >> singular);
    EXPECT_EQ(method, b.reml ? "REML" : "ML");
    EXPECT_EQ(singular, "TRUE");
    EXPECT_EQ(th[2], 0.0);
    EXPECT_LE(fit.deviance, crit + 1e-10 * std::abs(crit));
    EXPECT_LE(rel(fit.deviance, crit), 1e-10);
    EXPECT_LE(rel(fit.theta[0], th[0]), 2e-5);
    EXPECT_LE(rel(fit.sigma, sigma), 1e-5);
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(fit.fixed[j].estimate, beta[j], 1e-10) << j;
  }
}

// A fixed effect that is also the grouping factor printed df 0.000, p 1.3e-08 and partial
// eta^2 1.000 [0, 0] with exit 0 (review finding); the grouping factor as the response or the
// slope crashed (segmentation fault). All are located formula errors now.
TEST(LmmFormula, UnidentifiableModelsAreFormulaErrors) {
  auto err = [](const std::string& f) {
    try {
      parse_lmm_formula(f);
    } catch (const palplab::InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  std::string e = err("value ~ group + (1 | group)");
  EXPECT_NE(e.find("(at character 9)"), std::string::npos) << e;
  EXPECT_NE(e.find("fixed-effect term 'group' is also the random-effects grouping factor"),
            std::string::npos)
      << e;
  e = err("value ~ session * participant + (1 + session | participant)");
  EXPECT_NE(e.find("'participant' is also the random-effects grouping factor"), std::string::npos)
      << e;
  EXPECT_NE(err("participant ~ x + (1 | participant)").find("is also the grouping factor"),
            std::string::npos);
  EXPECT_NE(err("y ~ x + (g | g)").find("random slope 'g' is also the grouping factor"),
            std::string::npos);
  EXPECT_NE(err("y ~ x + (1 + y | g)").find("is also the random slope"), std::string::npos);
  EXPECT_EQ(err("y ~ x + (1 + x | g)"), "no error");
}

// The same confounding under another name: a fixed factor that recodes the grouping factor.
TEST(LmmFit, RandomEffectsDeterminedByTheFixedEffectsAreRefused) {
  CsvTable t = read_csv(kDir + "study.csv");
  t.header.push_back("alias");
  for (auto& row : t.rows) row.push_back("Q" + row[0]);
  t.field_line.clear();  // positions no longer match the widened rows
  t.field_column.clear();
  auto err = [&](const std::string& f) {
    try {
      fit_lmm(t, parse_lmm_formula(f), {}, true);
    } catch (const palplab::InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string e = err("value ~ alias + (1 | participant)");
  EXPECT_NE(e.find("the random intercepts of 'participant' are fully determined by the fixed "
                   "effects"),
            std::string::npos)
      << e;
  EXPECT_NE(err("value ~ session + alias + (1 + session | participant)").find("not identifiable"),
            std::string::npos);
  EXPECT_EQ(err("value ~ group * session + (1 + session | participant)"), "no error");
}

// A covariate in units that make it huge (session x 1e15, as when a time is stored in fs) spans
// the same full-rank design as session: it was "rank deficient" because the QR's rank test
// measured the intercept against a column 1e15 times longer. The columns are now equilibrated
// (divided by a power of two near their RMS) before the rank test and the fit, and the
// estimates unscaled. Compared with the fit on the covariate itself: on balanced data
// (sleepstudy: the GLS estimates do not depend on theta) the fixed effects agree to 1e-10
// relative. Everything that depends on theta agrees as two fits of the same model in other
// units do: the optimiser fixes theta to ~1e-8 relative (study.csv with session x 2, which needs
// no scaling, moves theta by 1.1e-8 as well), hence 1e-6 for theta, SEs, t, df and F, and on
// the unbalanced study.csv 1e-8 for the estimates (5e-10 seen). The REML criterion gains
// exactly 2 log(scale) per scaled column (its log|X'V^-1 X|), the ML deviance nothing.
namespace {
CsvTable with_scaled_column(const std::string& file, int col, const std::string& factor) {
  CsvTable t = read_csv(kDir + file);
  t.header.push_back(t.header[col] + "_s");
  for (auto& row : t.rows) row.push_back(row[col] + factor);
  t.field_line.clear();  // positions no longer match the widened rows
  t.field_column.clear();
  return t;
}

// `formula` holds S where the covariate goes: once the column itself, once its scaled copy.
void expect_scaled_fit_equal(const std::string& file, int col, const std::string& formula,
                             double estimate_tol) {
  const std::string name = read_csv(kDir + file).header[col];
  for (const bool reml : {true, false})
    for (const auto& [factor, scale] :
         {std::pair{"e15", 1e15}, std::pair{"e-15", 1e-15}, std::pair{"e100", 1e100}}) {
      const std::string tag = formula + (reml ? " REML " : " ML ") + factor;
      const CsvTable t = with_scaled_column(file, col, factor);
      std::string f_plain = formula, f_scaled = formula;
      f_plain.replace(f_plain.find('S'), 1, name);
      f_scaled.replace(f_scaled.find('S'), 1, name + "_s");
      const LmmFit a = fit_lmm(t, parse_lmm_formula(f_plain), {}, reml);
      LmmFit b;
      ASSERT_NO_THROW(b = fit_lmm(t, parse_lmm_formula(f_scaled), {}, reml)) << tag;
      ASSERT_EQ(a.fixed.size(), b.fixed.size());
      int scaled_columns = 0;
      auto k = [&](size_t i) {
        return a.fixed[i].name.find(name) != std::string::npos ? scale : 1;
      };
      for (size_t i = 0; i < a.fixed.size(); ++i) {
        scaled_columns += k(i) != 1;
        const std::string w = tag + " " + a.fixed[i].name;
        expect_rel(b.fixed[i].estimate * k(i), a.fixed[i].estimate, estimate_tol, w + " estimate");
        expect_rel(b.fixed[i].se * k(i), a.fixed[i].se, 1e-6, w + " se");
        expect_rel(b.fixed[i].t, a.fixed[i].t, 1e-6, w + " t");
        expect_rel(b.fixed[i].df, a.fixed[i].df, 1e-6, w + " df");
        // p of t ~ 20 moves by ~t·Δt relative: 4.5e-7 seen for p ~ 3e-13.
        expect_rel(b.fixed[i].p, a.fixed[i].p, 2e-5, w + " p");
        for (size_t j = 0; j < a.fixed.size(); ++j)
          expect_rel(b.vcov[i][j] * k(i) * k(j), a.vcov[i][j], 1e-6, w + " vcov");
      }
      EXPECT_GT(scaled_columns, 0) << tag;
      for (size_t i = 0; i < a.theta.size(); ++i)
        expect_rel(b.theta[i], a.theta[i], 1e-6, tag + " theta");
      expect_rel(b.sigma, a.sigma, 1e-7, tag + " sigma");
      ASSERT_EQ(a.anova.size(), b.anova.size());
      for (size_t i = 0; i < a.anova.size(); ++i) {
        expect_rel(b.anova[i].f, a.anova[i].f, 1e-6, tag + " F " + a.anova[i].term);
        expect_rel(b.anova[i].den_df, a.anova[i].den_df, 1e-6, tag + " DenDF");
        expect_rel(b.anova[i].sum_sq, a.anova[i].sum_sq, 1e-6, tag + " Sum Sq");
      }
      const double shift = reml ? 2 * scaled_columns * std::log(scale) : 0;
      EXPECT_NEAR(b.deviance - a.deviance, shift, 1e-8 * (1 + std::abs(shift))) << tag;
    }
}
}  // namespace

TEST(LmmFit, BadlyScaledCovariateBalancedEstimatesTo1e10) {
  expect_scaled_fit_equal("sleepstudy.csv", 1, "Reaction ~ S + (1 | Subject)", 1e-10);
  expect_scaled_fit_equal("sleepstudy.csv", 1, "Reaction ~ S + (1 + Days | Subject)", 1e-10);
}

TEST(LmmFit, BadlyScaledCovariateWithInteractions) {
  expect_scaled_fit_equal("study.csv", 2, "value ~ group * S + (1 | participant)", 1e-8);
  expect_scaled_fit_equal("study.csv", 2, "value ~ group * S + (1 + session | participant)", 1e-8);
}

TEST(LmmFit, CollinearColumnsAreRankDeficientAtAnyScale) {
  const CsvTable t = with_scaled_column("study.csv", 2, "e15");
  try {
    fit_lmm(t, parse_lmm_formula("value ~ session + session_s + (1 | participant)"), {}, true);
    ADD_FAILURE() << "no error";
  } catch (const palplab::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("rank deficient (rank 2 < 3 columns)"), std::string::npos)
        << e.what();
  }
}

// The response in other units (x 1e100, x 1e-100, x 1e-140) is the same fit: df and p were n/a
// at 1e100 and the SDs 0 at 1e-170 (review 2026-12-06, fourth). Estimates, SEs, SDs and vcov
// scale with it; theta, t, df, p and F do not; the REML criterion gains 2 (n - p) log(scale),
// the ML deviance 2 n log(scale). Below 1e-150 the reported variances would underflow: refused
// (review 2026-12-06, fifth: variance 0 beside an SD of 1e-170).
TEST(LmmFit, TheResponsesUnitsDoNotChangeTheFit) {
  CsvTable base = read_csv(kDir + "sleepstudy.csv");
  const int y = column_index(base, "Reaction");
  for (const bool reml : {true, false})
    for (const auto& [factor, scale] :
         {std::pair{"e100", 1e100}, std::pair{"e-100", 1e-100}, std::pair{"e-140", 1e-140}}) {
      const std::string tag = std::string(reml ? "REML " : "ML ") + factor;
      CsvTable t = base;
      for (auto& row : t.rows) row[y] += factor;
      const auto f = parse_lmm_formula("Reaction ~ Days + (1 + Days | Subject)");
      const LmmFit a = fit_lmm(base, f, {}, reml);
      LmmFit b;
      ASSERT_NO_THROW(b = fit_lmm(t, f, {}, reml)) << tag;
      EXPECT_TRUE(b.warnings == a.warnings) << tag;
      ASSERT_EQ(a.fixed.size(), b.fixed.size());
      for (size_t i = 0; i < a.fixed.size(); ++i) {
        const std::string w = tag + " " + a.fixed[i].name;
        expect_rel(b.fixed[i].estimate / scale, a.fixed[i].estimate, 1e-9, w + " estimate");
        expect_rel(b.fixed[i].se / scale, a.fixed[i].se, 1e-6, w + " se");
        expect_rel(b.fixed[i].t, a.fixed[i].t, 1e-6, w + " t");
        expect_rel(b.fixed[i].df, a.fixed[i].df, 1e-6, w + " df");
        expect_rel(b.fixed[i].p, a.fixed[i].p, 2e-5, w + " p");
        expect_rel(b.vcov[i][i] / scale / scale, a.vcov[i][i], 1e-6, w + " vcov");
      }
      for (size_t i = 0; i < a.theta.size(); ++i)
        expect_rel(b.theta[i], a.theta[i], 1e-6, tag + " theta");
      expect_rel(b.sigma / scale, a.sigma, 1e-7, tag + " sigma");
      expect_rel(b.sd_intercept / scale, a.sd_intercept, 1e-6, tag + " sd intercept");
      expect_rel(b.sd_slope / scale, a.sd_slope, 1e-6, tag + " sd slope");
      ASSERT_EQ(a.anova.size(), b.anova.size());
      for (size_t i = 0; i < a.anova.size(); ++i) {
        expect_rel(b.anova[i].f, a.anova[i].f, 1e-6, tag + " F");
        expect_rel(b.anova[i].sum_sq / scale / scale, a.anova[i].sum_sq, 1e-6, tag + " Sum Sq");
      }
      const double shift = 2.0 * (reml ? a.n - a.p : a.n) * std::log(scale);
      EXPECT_NEAR(b.deviance - a.deviance, shift, 1e-8 * std::abs(shift)) << tag;
    }
  CsvTable tiny = base;
  for (auto& row : tiny.rows) row[y] += "e-170";
  std::string what = "no error";
  try {
    fit_lmm(tiny, parse_lmm_formula("Reaction ~ Days + (1 + Days | Subject)"), {}, true);
  } catch (const palplab::InputError& e) {
    what = e.what();
  }
  EXPECT_NE(what.find("column 'Reaction': the response's values are at most"), std::string::npos)
      << what;
  EXPECT_NE(what.find("rescale the column"), std::string::npos) << what;
}

// A response that hardly varies within participant (value = participant number + N(0, eps),
// 6 participants x 4 rows): the balanced one-way layout has the closed form
// sd_participant² = (MSB - MSW) / 4, SE(intercept) = sqrt(MSB / 24), df = 6 - 1 = 5. The fit
// loses precision as theta² (theta = sd_participant / sigma): with uniform noise of width 3e-3
// (theta ~2e3) it is the closed form to 2e-5 (the estimate to 1e-7) with a warning that says so; at
// eps 1e-6 (theta ~2e6) it gave df 21.6 and at eps 0 df 21.8 with no warning, at 1e-8 df -4.2
// (review 2026-12-06, fourth): now exit 2 naming the cause.
TEST(LmmFit, AResponseThatHardlyVariesWithinParticipantIsSaidSo) {
  auto table = [](double eps) {
    std::string text = "participant,value\n";
    std::uint64_t u = 12345;
    for (int g = 1; g <= 6; ++g)
      for (int j = 0; j < 4; ++j) {
        u = u * 6364136223846793005ull + 1442695040888963407ull;  // a fixed LCG: no std::rand
        const double noise = (static_cast<double>(u >> 11) / 9007199254740992.0 - 0.5) * eps;
        char buf[64];
        std::snprintf(buf, sizeof buf, "P%d,%.17g\n", g, g + noise);
        text += buf;
      }
    return parse_csv(text, "within.csv");
  };
  const auto f = parse_lmm_formula("value ~ 1 + (1 | participant)");
  {
    const CsvTable t = table(3e-3);
    const int y = column_index(t, "value");
    std::vector<double> mean(6, 0.0);
    double grand = 0;
    for (size_t r = 0; r < t.rows.size(); ++r) {
      const double v = std::stod(t.rows[r][y]);
      mean[r / 4] += v / 4;
      grand += v / 24;
    }
    double ssb = 0, ssw = 0;
    for (size_t r = 0; r < t.rows.size(); ++r) {
      const double v = std::stod(t.rows[r][y]);
      ssw += (v - mean[r / 4]) * (v - mean[r / 4]);
    }
    for (double m : mean) ssb += 4 * (m - grand) * (m - grand);
    const double msb = ssb / 5, msw = ssw / 18;
    const LmmFit fit = fit_lmm(t, f, {}, true);
    expect_rel(fit.sd_intercept, std::sqrt((msb - msw) / 4), 2e-5, "sd participant");
    expect_rel(fit.sigma, std::sqrt(msw), 1e-4, "sigma");
    expect_rel(fit.fixed[0].estimate, grand, 1e-7, "intercept");
    expect_rel(fit.fixed[0].se, std::sqrt(msb / 24), 2e-5, "se");
    expect_rel(fit.fixed[0].df, 5.0, 1e-3, "df");
    ASSERT_EQ(fit.warnings.size(), 1u);
    EXPECT_NE(fit.warnings[0].find("times the random-effect SD (the response hardly varies "
                                   "within the levels of 'participant')"),
              std::string::npos)
        << fit.warnings[0];
  }
  for (const double eps : {1e-6, 1e-8, 0.0}) {
    std::string what = "no error";
    try {
      fit_lmm(table(eps), f, {}, true);
    } catch (const palplab::InputError& e) {
      what = e.what();
    }
    EXPECT_NE(what.find("within.csv: the response 'value' hardly varies within the levels of "
                        "'participant'"),
              std::string::npos)
        << eps << ": " << what;
    EXPECT_NE(what.find("the mixed model is degenerate"), std::string::npos) << what;
  }
}

// A factor as random slope was a data error ("expected a decimal number ... got 'A'"): it is
// a model this implementation does not have, and the message now says so (review 2026-12-06,
// fourth), keeping the CSV location.
TEST(LmmFit, AFactorAsRandomSlopeIsSaidToBeUnsupported) {
  const CsvTable t = parse_csv(
      "participant,group,value\nP1,A,1\nP1,A,2\nP2,A,2\nP2,A,3\nP3,B,3\nP3,B,4\nP4,B,2\n"
      "P4,B,5\n",
      "f.csv");
  std::string what = "no error";
  try {
    fit_lmm(t, parse_lmm_formula("value ~ group + (group | participant)"), {}, true);
  } catch (const palplab::InputError& e) {
    what = e.what();
  }
  EXPECT_NE(what.find("f.csv:2:4: column 'group'"), std::string::npos) << what;
  EXPECT_NE(what.find("the random slope 'group' must be a numeric covariate"), std::string::npos)
      << what;
}
