#pragma once
// Linear mixed models with one random-effects term, `(1 | g)` or `(1 + x | g)`, fitted as lme4
// does (Bates, Mächler, Bolker & Walker 2015, JSS 67(1)): relative covariance factor
// Lambda(theta), penalised least squares by Cholesky, the profiled REML or ML deviance minimised
// over theta (bounded Nelder–Mead with restarts). Inference as lmerTest: Satterthwaite degrees of
// freedom from the gradient of each contrast's variance w.r.t. the variance parameters
// (theta, sigma) and the inverse Hessian of the (unprofiled) deviance, both by numerical
// differentiation; type III F tests with Satterthwaite denominator df.
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/csv.hpp"
#include "analysis/distributions.hpp"
#include "analysis/grouped.hpp"

namespace palplab::analysis {

// Parsed formula "y ~ a * b + c + (1 + x | g)". Fixed terms are sets of variable names in R's
// term order (by degree, then by appearance); the intercept is always present.
struct LmmFormula {
  std::string response;
  std::vector<std::vector<std::string>>
      terms;                             // e.g. {{"group"}, {"session"}, {"group","session"}}
  std::string group;                     // random-effects grouping factor
  std::string slope;                     // random slope covariate; empty for (1 | g)
  std::map<std::string, int> positions;  // every name's first mention (0-based character)
};
// Throws InputError (located as "--formula", column = 1-based character) for anything outside
// the supported grammar.
LmmFormula parse_lmm_formula(const std::string& text);

struct LmmFixedEffect {
  std::string name;  // lme4 name: "(Intercept)", "groupB", "session", "groupB:session"
  double estimate = 0, se = 0, t = 0, df = 0, p = 0;
};
struct LmmFTest {
  std::string term;  // "group", "group:session"
  int num_df = 0;
  double den_df = 0, f = 0, p = 0;
  double sum_sq = 0, mean_sq = 0;  // lmerTest's Sum Sq = F * num_df * sigma^2
  // Partial η² implied by the test, F·num_df / (F·num_df + den_df) (as R's effectsize does
  // for lmer), and its 95 % noncentral-F interval with the Satterthwaite den_df (f_effect_ci;
  // approximate: the F of a mixed model is only approximately noncentral F).
  double partial_eta_squared = 0;
  FEffectCi partial_eta_squared_ci;
};
struct LmmFit {
  bool reml = true;
  int n = 0, p = 0, n_groups = 0;
  std::string group, slope;
  std::vector<double> theta;  // lme4's theta (column-wise lower triangle of Lambda block)
  double sigma = 0;           // residual SD
  double sd_intercept = 0, sd_slope = 0, correlation = 0;  // random effects (slope: if any)
  double deviance = 0;  // REML criterion (reml) or -2 logLik (ML)
  double loglik = 0, aic = 0, bic = 0;
  int n_par = 0;  // p + #theta + 1
  std::vector<LmmFixedEffect> fixed;
  std::vector<std::vector<double>> vcov;  // p x p covariance of the fixed effects
  std::vector<LmmFTest> anova;            // type III, Satterthwaite
  std::vector<std::string> warnings;
  int rows_used = 0, rows_dropped_na = 0;
};

// Builds the model from the CSV rows passing `where` (rows with an empty/NA value in a used
// column are dropped and counted, as R's na.omit does) and fits it.
LmmFit fit_lmm(const CsvTable& t, const LmmFormula& f, const std::vector<WhereFilter>& where,
               bool reml = true);

std::string to_text(const LmmFit& fit, const std::string& formula);
nlohmann::json to_json(const LmmFit& fit);

// Low level, for tests: profiled deviance of a model given as dense matrices; `z` is n x k
// (k = 1 or 2 random-effect columns) and `g` the 0-based group of each row.
struct LmmData {
  std::vector<double> y;               // n
  std::vector<std::vector<double>> x;  // n rows of p
  std::vector<std::vector<double>> z;  // n rows of k
  std::vector<int> g;                  // n
  int n_groups = 0;
};
double lmm_profiled_deviance(const LmmData& d, const std::vector<double>& theta, bool reml);

}  // namespace palplab::analysis
