#include "analysis/lmm.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <sstream>

#include "analysis/distributions.hpp"
#include "analysis/summary.hpp"
#include "common/escape.hpp"
#include "common/format.hpp"
#include "common/input_error.hpp"

namespace palplab::analysis {

namespace {
// lme4's isSingular() tolerance on the diagonal of the relative covariance factor.
constexpr double kSingularTol = 1e-4;

using Eigen::MatrixXd;
using Eigen::VectorXd;

// Column equilibration of a design: a column whose RMS lies outside [2^-10, 2^10] (a covariate
// in units that make it 1e15) is divided by the power of two nearest its RMS (exact in binary);
// the others are left as they are. Without it the rank test of the QR measured the intercept
// against a column 1e15 times larger and called a full-rank design (session x 1e15 beside
// the intercept) rank deficient. Returns the divisor of each column (1 = unchanged).
VectorXd equilibrate(MatrixXd& X) {
  VectorXd scale = VectorXd::Ones(X.cols());
  for (Eigen::Index j = 0; j < X.cols(); ++j) {
    const double rms = X.col(j).norm() / std::sqrt(static_cast<double>(X.rows()));
    if (!(rms > 0) || !std::isfinite(rms) || (rms >= 0x1p-10 && rms <= 0x1p10)) continue;
    scale(j) = std::exp2(std::round(std::log2(rms)));
    X.col(j) /= scale(j);
  }
  return scale;
}

[[noreturn]] void formula_error(int pos, const std::string& what) {
  throw InputError(SourceLocation{"--formula", 0, pos + 1},
                   what + " (at character " + std::to_string(pos + 1) + ")");
}

struct Token {
  char kind;  // 'n' name, '1' the number one, or one of ~ + * : ( ) |
  std::string text;
  int pos;
};

// A non-ASCII character that looks like an operator or a space, pasted from a word processor or
// a paper (a Unicode minus, ×, a no-break space): what it is taken for, said in the error. It
// would otherwise be read as part of a name ("a×b" one name, "a\u00A0" a column not found).
const char* lookalike(char32_t cp) {
  static const std::vector<std::pair<std::u32string, const char*>> kinds = {
      {U"\u00A0\u1680\u202F\u205F\u3000\uFEFF", "a Unicode space: use an ordinary space"},
      {U"\u00D7\u00B7\u22C5\u2217\u2219\uFF0A\u2715\u2716", "use '*' for an interaction"},
      {U"\u200C\u200D\u2060\u00AD\u2028\u2029",
       "an invisible character (a joiner, a soft hyphen or a line separator): delete it"},
      {U"\u2212\u2010\u2011\u2012\u2013\u2014\uFE63\uFF0D",
       "a minus or dash: terms are only added ('+'; no '- 1')"},
      {U"\uFF0B\u2795", "use the ASCII '+'"},
      {U"\uFF5E\u223C\u301C", "use the ASCII '~'"},
      {U"\uFF5C\u2223\u00A6\u2502", "use the ASCII '|'"},
      {U"\uFF1A\u2236", "use the ASCII ':'"},
      {U"\uFF08\uFF09", "use the ASCII '(' and ')'"},
      {U"\u2018\u2019\u201C\u201D\u00AB\u00BB", "names are written without quotes"},
      {U"\uFFFD", "not UTF-8"}};
  for (const auto& [cps, what] : kinds)
    if (cps.find(cp) != std::u32string::npos) return what;
  return cp >= 0x2000 && cp <= 0x200B ? "a Unicode space: use an ordinary space" : nullptr;
}

// Positions count characters (UTF-8 code points), as editors and the message do. Names are
// letters, digits, '_' and '.', and any non-ASCII character but the look-alikes above (R takes a
// locale's letters in names: a column "Größe"), so a CSV's non-ASCII header can be named.
std::vector<Token> tokenize(const std::string& s) {
  std::vector<Token> out;
  const std::string supported = "supported: y ~ a * b + c:d + (1 | g) or (1 + x | g)";
  // The character at s[i]: its length, and whether it belongs to a name.
  const auto at = [&](size_t i, size_t* len) {
    const char32_t cp = utf8_code_point(s, i, len);
    const bool name = cp < 0x80 ? std::isalnum(static_cast<int>(cp)) || cp == '_' || cp == '.'
                                : lookalike(cp) == nullptr;
    return std::pair{cp, name};
  };
  int cp_index = 0;  // the character index of s[i]
  for (size_t i = 0; i < s.size();) {
    size_t len = 1;
    const auto [cp, name] = at(i, &len);
    const char c = s[i];
    if (c == ' ' || c == '\t') {
      ++i;
      ++cp_index;
    } else if (name) {
      size_t j = i;
      int n = 0;
      for (size_t l = 1; j < s.size() && at(j, &l).second; j += l) ++n;
      std::string w = s.substr(i, j - i);
      if (std::isdigit(static_cast<unsigned char>(w[0])) && w != "1")
        formula_error(cp_index, "only the number 1 (intercept) may appear in a formula, got '" +
                                    shown_text(w) + "'");
      out.push_back({w == "1" ? '1' : 'n', w, cp_index});
      i = j;
      cp_index += n;
    } else if (cp < 0x80 && std::string("~+*:()|").find(c) != std::string::npos) {
      out.push_back({c, std::string(1, c), cp_index});
      ++i;
      ++cp_index;
    } else if (const char* what = lookalike(cp)) {
      char u[16];
      if (cp == 0xFFFD && len == 1) {  // an ill-formed byte (U+FFFD itself is 3 bytes)
        std::snprintf(u, sizeof u, "0x%02X", static_cast<unsigned char>(c));
        formula_error(cp_index,
                      std::string("unexpected byte ") + u + " (not UTF-8; " + supported + ")");
      }
      std::snprintf(u, sizeof u, "U+%04X", static_cast<unsigned>(cp));
      formula_error(cp_index, "unexpected character '" + shown_text(s.substr(i, len)) + "' (" + u +
                                  ", " + what + "; " + supported + ")");
    } else {
      formula_error(cp_index, "unexpected character '" + shown_text(s.substr(i, len)) + "' (" +
                                  supported + ")");
    }
  }
  return out;
}

// The formula's length in characters (the position of "the end").
int char_count(const std::string& s) {
  return static_cast<int>(utf8_length(s));
}

}  // namespace

LmmFormula parse_lmm_formula(const std::string& text) {
  auto tok = tokenize(text);
  LmmFormula f;
  size_t i = 0;
  const int end = char_count(text);
  auto at = [&](size_t k) { return k < tok.size() ? tok[k].pos : end; };
  if (i >= tok.size() || tok[i].kind != 'n') formula_error(at(i), "expected the response name");
  f.positions.emplace(tok[i].text, tok[i].pos);
  f.response = tok[i++].text;
  if (i >= tok.size() || tok[i].kind != '~') formula_error(at(i), "expected '~' after response");
  ++i;
  std::vector<std::string> var_order;  // first appearance
  auto note_var = [&](const std::string& v) {
    if (std::find(var_order.begin(), var_order.end(), v) == var_order.end()) var_order.push_back(v);
  };
  std::vector<std::vector<std::string>> raw_terms;
  std::vector<int> raw_pos;              // where each raw term's product chain starts in the text
  std::map<std::string, int> fixed_pos;  // fixed-effect variable -> position in the text
  int group_pos = 0, slope_pos = 0;
  bool have_random = false, expect_operand = true;
  while (i < tok.size()) {
    if (!expect_operand) {
      if (tok[i].kind != '+') formula_error(tok[i].pos, "expected '+' between terms");
      ++i;
      expect_operand = true;
      continue;
    }
    if (tok[i].kind == '(') {
      // Random-effects term: ( 1 | g ) or ( 1 + x | g )
      int start = tok[i].pos;
      if (have_random) formula_error(start, "only one random-effects term is supported");
      have_random = true;
      ++i;
      // (1 | g), (1 + x | g) or lme4's shorthand (x | g), which includes the intercept
      if (i < tok.size() && tok[i].kind == 'n') {
        slope_pos = tok[i].pos;
        f.positions.emplace(tok[i].text, tok[i].pos);
        f.slope = tok[i++].text;
      } else {
        if (i >= tok.size() || tok[i].kind != '1')
          formula_error(at(i), "a random-effects term must be (1 | g), (1 + x | g) or (x | g)");
        ++i;
        if (i < tok.size() && tok[i].kind == '+') {
          ++i;
          if (i >= tok.size() || tok[i].kind != 'n')
            formula_error(at(i), "expected the random slope variable after '1 +'");
          slope_pos = tok[i].pos;
          f.positions.emplace(tok[i].text, tok[i].pos);
          f.slope = tok[i++].text;
        }
      }
      if (i >= tok.size() || tok[i].kind != '|')
        formula_error(at(i), "expected '|' in the random-effects term (1 | g) or (1 + x | g)");
      ++i;
      if (i >= tok.size() || tok[i].kind != 'n')
        formula_error(at(i), "expected the grouping factor after '|'");
      group_pos = tok[i].pos;
      f.positions.emplace(tok[i].text, tok[i].pos);
      f.group = tok[i++].text;
      if (i >= tok.size() || tok[i].kind != ')')
        formula_error(at(i),
                      "expected ')' closing the random-effects term (one grouping factor, "
                      "no nesting)");
      ++i;
      expect_operand = false;
      continue;
    }
    if (tok[i].kind == '1') {  // explicit intercept: already included
      ++i;
      expect_operand = false;
      continue;
    }
    if (tok[i].kind != 'n') formula_error(tok[i].pos, "expected a variable name");
    // product chain: segments separated by '*', each a ':'-joined interaction
    std::vector<std::vector<std::string>> segments{{}};
    const int chain_pos = tok[i].pos;
    while (true) {
      if (i >= tok.size() || tok[i].kind != 'n') formula_error(at(i), "expected a variable name");
      note_var(tok[i].text);
      fixed_pos.emplace(tok[i].text, tok[i].pos);  // the first mention
      f.positions.emplace(tok[i].text, tok[i].pos);
      segments.back().push_back(tok[i++].text);
      if (i < tok.size() && tok[i].kind == ':') {
        ++i;
      } else if (i < tok.size() && tok[i].kind == '*') {
        ++i;
        segments.emplace_back();
      } else {
        break;
      }
    }
    const size_t ns = segments.size();
    for (size_t mask = 1; mask < (size_t{1} << ns); ++mask) {
      std::vector<std::string> term;
      for (size_t s = 0; s < ns; ++s)
        if (mask & (size_t{1} << s))
          term.insert(term.end(), segments[s].begin(), segments[s].end());
      raw_terms.push_back(term);
      raw_pos.push_back(chain_pos);
    }
    expect_operand = false;
  }
  if (expect_operand) formula_error(end, "formula ends after an operator");
  if (!have_random) formula_error(end, "a random-effects term (1 | g) or (1 + x | g) is required");
  // canonical terms: variables in order of first appearance, duplicates removed, sorted by degree
  auto rank = [&](const std::string& v) {
    return std::find(var_order.begin(), var_order.end(), v) - var_order.begin();
  };
  std::vector<std::vector<std::string>> terms;
  std::map<std::vector<std::string>, int> term_pos;  // where a term is first written
  for (std::size_t r = 0; r < raw_terms.size(); ++r) {
    auto t = raw_terms[r];
    std::sort(t.begin(), t.end(), [&](auto& a, auto& b) { return rank(a) < rank(b); });
    t.erase(std::unique(t.begin(), t.end()), t.end());
    term_pos.emplace(t, raw_pos[r]);
    if (std::find(terms.begin(), terms.end(), t) == terms.end()) terms.push_back(t);
  }
  std::stable_sort(terms.begin(), terms.end(),
                   [](auto& a, auto& b) { return a.size() < b.size(); });
  // Only hierarchical models: R codes a factor in an interaction without its margin by full
  // dummies, which this implementation does not reproduce.
  for (const auto& t : terms) {
    if (t.size() < 2) continue;
    for (size_t drop = 0; drop < t.size(); ++drop) {
      std::vector<std::string> sub;
      for (size_t k = 0; k < t.size(); ++k)
        if (k != drop) sub.push_back(t[k]);
      if (std::find(terms.begin(), terms.end(), sub) == terms.end()) {
        std::string name;
        for (auto& v : t) name += (name.empty() ? "" : ":") + v;
        // Where the term is written (it said character 1, review 2026-12-06, fourth; then the
        // first mention of its first variable, fifth).
        const auto at_term = term_pos.find(t);
        formula_error(at_term != term_pos.end() ? at_term->second : 0,
                      "interaction '" + name +
                          "' without all its lower-order terms is not supported (use '*')");
      }
    }
  }
  for (const auto& t : terms)
    for (const auto& v : t)
      if (v == f.response) {
        const auto at_var = fixed_pos.find(v);
        formula_error(at_var != fixed_pos.end() ? at_var->second : 0,
                      "the response '" + v + "' is also a predictor");
      }
  // Models that cannot be estimated (they used to print df 0 and p 1e-8, or crash):
  if (f.group == f.response)
    formula_error(group_pos, "the response '" + f.response + "' is also the grouping factor");
  if (f.slope == f.response)
    formula_error(slope_pos, "the response '" + f.response + "' is also the random slope");
  if (f.slope == f.group)
    formula_error(slope_pos, "the random slope '" + f.slope +
                                 "' is also the grouping factor (a slope needs a numeric "
                                 "column that varies within the levels of '" +
                                 f.group + "')");
  // A fixed effect of the grouping factor gives every level its own fixed mean, which the
  // random intercepts of the same levels also are: the variance of the random intercepts and
  // the fixed effects are not identifiable (both explain the same level means).
  if (auto it = fixed_pos.find(f.group); it != fixed_pos.end())
    formula_error(it->second,
                  "the fixed-effect term '" + f.group +
                      "' is also the random-effects grouping factor ('| " + f.group +
                      "'): its fixed effects and the random intercepts both model one mean "
                      "per level, so the model is not identifiable; remove '" +
                      f.group + "' from the fixed effects or group by another column");
  f.terms = terms;
  return f;
}

namespace {

// Per-group sufficient statistics and the pieces of one evaluation at theta.
struct Model {
  int n = 0, p = 0, k = 1, m = 0;  // rows, fixed columns, random columns per group, groups
  MatrixXd X, Z;                   // n x p, n x k
  VectorXd y;
  std::vector<int> g;
  std::vector<MatrixXd> ZtZ, ZtX;  // per group: k x k, k x p
  std::vector<VectorXd> Zty;       // per group: k
  MatrixXd XtX;
  VectorXd Xty;
  bool reml = true;
};

struct Eval {
  double ldL2 = 0, ldRX2 = 0, r2 = 0;
  VectorXd beta;
  MatrixXd Minv;  // (RX'RX)^-1: unscaled covariance of beta
};

MatrixXd lambda_block(const std::vector<double>& th, int k) {
  MatrixXd T = MatrixXd::Zero(k, k);
  if (k == 1) {
    T(0, 0) = th[0];
  } else {
    T(0, 0) = th[0];
    T(1, 0) = th[1];
    T(1, 1) = th[2];
  }
  return T;
}

Eval evaluate(const Model& md, const std::vector<double>& th) {
  Eval e;
  const MatrixXd T = lambda_block(th, md.k);
  MatrixXd M = md.XtX;
  VectorXd rhs = md.Xty;
  std::vector<Eigen::LLT<MatrixXd>> L(md.m);
  std::vector<MatrixXd> RZX(md.m);
  std::vector<VectorXd> cu(md.m);
  for (int i = 0; i < md.m; ++i) {
    MatrixXd A = T.transpose() * md.ZtZ[i] * T + MatrixXd::Identity(md.k, md.k);
    L[i].compute(A);
    MatrixXd Lm = L[i].matrixL();
    for (int d = 0; d < md.k; ++d) e.ldL2 += 2 * std::log(Lm(d, d));
    RZX[i] = L[i].matrixL().solve(T.transpose() * md.ZtX[i]);
    cu[i] = L[i].matrixL().solve(T.transpose() * md.Zty[i]);
    M.noalias() -= RZX[i].transpose() * RZX[i];
    rhs.noalias() -= RZX[i].transpose() * cu[i];
  }
  Eigen::LLT<MatrixXd> RX(M);
  MatrixXd RL = RX.matrixL();
  for (int d = 0; d < md.p; ++d) e.ldRX2 += 2 * std::log(RL(d, d));
  e.beta = RX.solve(rhs);
  e.Minv = RX.solve(MatrixXd::Identity(md.p, md.p));
  // Penalised residual sum of squares computed from the residuals themselves (no cancellation
  // of y'y against fitted sums of squares).
  std::vector<VectorXd> b(md.m);
  double pen = 0;
  for (int i = 0; i < md.m; ++i) {
    VectorXd u = L[i].matrixU().solve(cu[i] - RZX[i] * e.beta);
    pen += u.squaredNorm();
    b[i] = T * u;
  }
  VectorXd res = md.y - md.X * e.beta;
  for (int r = 0; r < md.n; ++r) res(r) -= md.Z.row(r).dot(b[md.g[r]]);
  e.r2 = res.squaredNorm() + pen;
  return e;
}

double profiled(const Model& md, const Eval& e) {
  const double two_pi = 2 * std::numbers::pi;
  if (!md.reml) return e.ldL2 + md.n * (1 + std::log(two_pi * e.r2 / md.n));
  const double nmp = md.n - md.p;
  return e.ldL2 + e.ldRX2 + nmp * (1 + std::log(two_pi * e.r2 / nmp));
}

// lmerTest's devfun_vp: the deviance as a function of (theta, sigma), not profiled over sigma.
double deviance_vp(const Model& md, const std::vector<double>& vp) {
  std::vector<double> th(vp.begin(), vp.end() - 1);
  const double s2 = vp.back() * vp.back();
  Eval e = evaluate(md, th);
  const double l2ps = std::log(2 * std::numbers::pi * s2);
  double dev = e.ldL2 + e.r2 / s2 + md.n * l2ps;
  if (md.reml) dev += e.ldRX2 - md.p * l2ps;
  return dev;
}

MatrixXd vcov_vp(const Model& md, const std::vector<double>& vp) {
  std::vector<double> th(vp.begin(), vp.end() - 1);
  return vp.back() * vp.back() * evaluate(md, th).Minv;
}

// Bounded Nelder–Mead: points are projected onto the box before evaluation.
std::vector<double> nelder_mead(const std::function<double(const std::vector<double>&)>& f0,
                                std::vector<double> x0, const std::vector<double>& lower,
                                double step, double* fbest) {
  const size_t d = x0.size();
  auto proj = [&](std::vector<double> x) {
    for (size_t j = 0; j < d; ++j) x[j] = std::max(x[j], lower[j]);
    return x;
  };
  auto f = [&](const std::vector<double>& x) {
    double v = f0(proj(x));
    return std::isfinite(v) ? v : std::numeric_limits<double>::max();
  };
  std::vector<std::vector<double>> s(d + 1, proj(x0));
  for (size_t j = 0; j < d; ++j) s[j + 1][j] += step;
  std::vector<double> fv(d + 1);
  for (size_t j = 0; j <= d; ++j) fv[j] = f(s[j]);
  double best_seen = *std::min_element(fv.begin(), fv.end());
  int stall = 0;
  for (int it = 0; it < 20000; ++it) {
    std::vector<size_t> idx(d + 1);
    for (size_t j = 0; j <= d; ++j) idx[j] = j;
    std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return fv[a] < fv[b]; });
    auto s2 = s;
    auto f2 = fv;
    for (size_t j = 0; j <= d; ++j) s[j] = s2[idx[j]], fv[j] = f2[idx[j]];
    // Size relative to the coordinate's magnitude (absolute below 1): a theta of 8e6 (a
    // random-intercept SD far above the residual SD) has ulps of 2e-9 and could never meet an
    // absolute 1e-11.
    double size = 0;
    for (size_t j = 1; j <= d; ++j)
      for (size_t c = 0; c < d; ++c)
        size = std::max(size, std::abs(s[j][c] - s[0][c]) / std::max(1.0, std::abs(s[0][c])));
    // Stall: the best value has not fallen by more than its rounding for 50·(d + 1) iterations.
    // On a singular fit the simplex collapses to a few ulps of theta while the deviance there
    // still differs by ~5e-15 relative between neighbouring doubles (rounding of the
    // evaluation), so the value-spread test below can never pass and the search used to run to
    // its 20000-iteration cap (0.6 s per fit). Only the termination changes, not the path.
    if (fv[0] < best_seen - 1e-15 * std::abs(best_seen)) {
      best_seen = fv[0];
      stall = 0;
    } else {
      ++stall;
    }
    if (size < 1e-11 &&
        (fv[d] - fv[0] <= 1e-15 * std::abs(fv[0]) || stall > 50 * static_cast<int>(d + 1)))
      break;
    std::vector<double> cen(d, 0);
    for (size_t j = 0; j < d; ++j)
      for (size_t c = 0; c < d; ++c) cen[c] += s[j][c] / d;
    auto along = [&](double a) {
      std::vector<double> x(d);
      for (size_t c = 0; c < d; ++c) x[c] = cen[c] + a * (s[d][c] - cen[c]);
      return x;
    };
    auto xr = along(-1);
    double fr = f(xr);
    if (fr < fv[0]) {
      auto xe = along(-2);
      double fe = f(xe);
      if (fe < fr)
        s[d] = xe, fv[d] = fe;
      else
        s[d] = xr, fv[d] = fr;
    } else if (fr < fv[d - 1]) {
      s[d] = xr, fv[d] = fr;
    } else {
      auto xc = fr < fv[d] ? along(-0.5) : along(0.5);
      double fc = f(xc);
      if (fc < std::min(fr, fv[d])) {
        s[d] = xc, fv[d] = fc;
      } else {
        for (size_t j = 1; j <= d; ++j) {
          for (size_t c = 0; c < d; ++c) s[j][c] = s[0][c] + 0.5 * (s[j][c] - s[0][c]);
          fv[j] = f(s[j]);
        }
      }
    }
  }
  size_t b = std::min_element(fv.begin(), fv.end()) - fv.begin();
  *fbest = fv[b];
  return proj(s[b]);
}

// Central differences at h, h/2, h/4 with two Richardson steps (truncation error O(h^6)), so
// that h can be large enough to keep the round-off of the deviance (~1e-16 * |dev|) negligible.
template <class F>
auto richardson(F&& central, double h) {
  auto d1 = central(h);
  auto d2 = central(h / 2);
  auto d3 = central(h / 4);
  auto r1 = ((4.0 * d2 - d1) / 3.0).eval();
  auto r2 = ((4.0 * d3 - d2) / 3.0).eval();
  return ((16.0 * r2 - r1) / 15.0).eval();
}

struct Column {
  std::string name;
  bool numeric = false;
  std::vector<double> num;          // per used row
  std::vector<std::string> level;   // per used row (factors)
  std::vector<std::string> levels;  // sorted (factors)
};

// Design columns of the fixed terms; `sum_coding` switches factors from treatment to sum
// contrasts (used to build type III hypotheses). Returns n x p and fills names / term of col.
MatrixXd design(const std::vector<std::vector<std::string>>& terms,
                const std::map<std::string, Column>& cols, int n, bool sum_coding,
                std::vector<std::string>* names, std::vector<int>* term_of) {
  std::vector<VectorXd> out{VectorXd::Ones(n)};
  names->assign(1, "(Intercept)");
  term_of->assign(1, -1);
  for (size_t ti = 0; ti < terms.size(); ++ti) {
    std::vector<VectorXd> acc{VectorXd::Ones(n)};
    std::vector<std::string> accn{""};
    for (const auto& v : terms[ti]) {
      const Column& c = cols.at(v);
      std::vector<VectorXd> vc;
      std::vector<std::string> vn;
      if (c.numeric) {
        vc.push_back(Eigen::Map<const VectorXd>(c.num.data(), n));
        vn.push_back(v);
      } else {
        const size_t K = c.levels.size();
        for (size_t l = 1; l < K; ++l) {
          VectorXd col(n);
          for (int r = 0; r < n; ++r) {
            if (!sum_coding) {
              col(r) = c.level[r] == c.levels[l] ? 1 : 0;
            } else {  // sum contrasts: level l-1 -> +1, last level -> -1
              col(r) = c.level[r] == c.levels[l - 1] ? 1 : (c.level[r] == c.levels[K - 1] ? -1 : 0);
            }
          }
          vc.push_back(col);
          vn.push_back(v + (sum_coding ? std::to_string(l) : c.levels[l]));
        }
      }
      std::vector<VectorXd> nacc;
      std::vector<std::string> naccn;
      for (size_t j = 0; j < vc.size(); ++j)
        for (size_t a = 0; a < acc.size(); ++a) {
          nacc.push_back(acc[a].cwiseProduct(vc[j]));
          naccn.push_back(accn[a].empty() ? vn[j] : accn[a] + ":" + vn[j]);
        }
      acc = nacc;
      accn = naccn;
    }
    for (size_t a = 0; a < acc.size(); ++a) {
      out.push_back(acc[a]);
      names->push_back(accn[a]);
      term_of->push_back(static_cast<int>(ti));
    }
  }
  MatrixXd X(n, out.size());
  for (size_t j = 0; j < out.size(); ++j) X.col(j) = out[j];
  return X;
}

bool is_missing(const std::string& s) {
  return s.empty() || s == "NA";
}

}  // namespace

double lmm_profiled_deviance(const LmmData& d, const std::vector<double>& theta, bool reml) {
  Model md;
  md.n = static_cast<int>(d.y.size());
  md.p = static_cast<int>(d.x.at(0).size());
  md.k = static_cast<int>(d.z.at(0).size());
  md.m = d.n_groups;
  md.reml = reml;
  md.X.resize(md.n, md.p);
  md.Z.resize(md.n, md.k);
  md.y = Eigen::Map<const VectorXd>(d.y.data(), md.n);
  md.g = d.g;
  for (int r = 0; r < md.n; ++r) {
    for (int j = 0; j < md.p; ++j) md.X(r, j) = d.x[r][j];
    for (int j = 0; j < md.k; ++j) md.Z(r, j) = d.z[r][j];
  }
  md.ZtZ.assign(md.m, MatrixXd::Zero(md.k, md.k));
  md.ZtX.assign(md.m, MatrixXd::Zero(md.k, md.p));
  md.Zty.assign(md.m, VectorXd::Zero(md.k));
  for (int r = 0; r < md.n; ++r) {
    int gi = md.g[r];
    md.ZtZ[gi] += md.Z.row(r).transpose() * md.Z.row(r);
    md.ZtX[gi] += md.Z.row(r).transpose() * md.X.row(r);
    md.Zty[gi] += md.Z.row(r).transpose() * md.y(r);
  }
  md.XtX = md.X.transpose() * md.X;
  md.Xty = md.X.transpose() * md.y;
  return profiled(md, evaluate(md, theta));
}

LmmFit fit_lmm(const CsvTable& t, const LmmFormula& f, const std::vector<WhereFilter>& where,
               bool reml) {
  std::vector<int> rows = filter_rows(t, where);
  // variables used
  std::vector<std::string> vars{f.response, f.group};
  if (!f.slope.empty()) vars.push_back(f.slope);
  for (auto& term : f.terms)
    for (auto& v : term)
      if (std::find(vars.begin(), vars.end(), v) == vars.end()) vars.push_back(v);
  std::map<std::string, int> ci;
  for (auto& v : vars) {
    // A name that is no column is the formula's mistake (or the file's): said at the name.
    if (std::find(t.header.begin(), t.header.end(), v) == t.header.end()) {
      const auto at = f.positions.find(v);
      const int pos = at != f.positions.end() ? at->second : 0;
      // An accent typed as a letter plus a combining mark (U+0300..U+036F, NFD: macOS file
      // names, some keyboards) never equals the precomposed letter (NFC) that looks the same.
      const auto combining_count = [](const std::string& x) {
        size_t k = 0;
        for (size_t i = 0, n = 0; i < x.size(); i += n)
          if (const char32_t c = utf8_code_point(x, i, &n); c >= 0x300 && c <= 0x36F) ++k;
        return k;
      };
      const auto combining = [&](const std::string& x) { return combining_count(x) > 0; };
      std::string hint;
      if (combining(v))
        hint = " ('" + shown_text(v) +
               "' is written with a combining accent (Unicode NFD), which never equals a "
               "precomposed letter (NFC) that looks the same: type the name again)";
      else if (utf8_length(v) != v.size())
        for (const auto& h : t.header)
          // The column looks like the name: as many characters once its accents are not counted.
          if (combining(h) && utf8_length(h) - combining_count(h) == utf8_length(v)) {
            hint = " (the column '" + shown_text(h) +
                   "' is written with a combining accent (Unicode NFD), which never equals a "
                   "precomposed letter (NFC) that looks the same: copy the name from the CSV, "
                   "or save the CSV in NFC)";
            break;
          }
      throw InputError(SourceLocation{"--formula", 0, pos + 1},
                       "no column '" + shown_text(v) + "' in " + t.file + " (at character " +
                           std::to_string(pos + 1) + "); its columns are: " +
                           shown_columns(t.header) + hint + separator_hint(t.header));
    }
    ci[v] = column_index(t, v);
  }
  LmmFit fit;
  fit.reml = reml;
  std::vector<int> used;
  for (int r : rows) {
    bool miss = false;
    for (auto& [v, c] : ci) miss = miss || is_missing(trim_blanks(t.rows[r][c]));
    if (miss)
      ++fit.rows_dropped_na;
    else
      used.push_back(r);
  }
  if (!where.empty() && rows.empty())
    throw InputError(no_row_matches(t, where, shown_where_flags(where)));
  if (used.empty())
    throw InputError(std::string("no complete data rows") +
                         (where.empty() ? "" : " among those matching the --where filters") + " (" +
                         std::to_string(fit.rows_dropped_na) + " with NA dropped)",
                     t.file);
  // One response: a tidy table's rows of several measures pooled into one variable (accuracy
  // in %, times in s and forces in N) were fitted as one (review 2026-12-07).
  check_one_measure(t, used, f.response, "--where ");
  const int n = static_cast<int>(used.size());
  std::map<std::string, Column> cols;
  for (auto& v : vars) {
    Column c;
    c.name = v;
    c.numeric = true;
    for (int r : used) {
      try {
        c.num.push_back(parse_number(t, r, ci[v]));
      } catch (const InputError& e) {
        if (v == f.response) throw;  // located "expected a number"
        // A factor as random slope (`(group | participant)`) was "expected a decimal number":
        // a data error for a model this implementation does not have.
        if (v == f.slope)
          throw InputError(std::string(e.what()) + "; the random slope '" + v +
                           "' must be a numeric covariate (e.g. a session number): a factor "
                           "as random slope, as in (" +
                           v + " | " + f.group + "), is not supported");
        c.numeric = false;
        // A numeric covariate with a typo became a factor of every value seen, without a word
        // (review 2026-12-07: one 'x' among session numbers gave a 5-df session term).
        if (v != f.group) {
          int numbers = 0;
          for (int u : used) {
            try {
              parse_number(t, u, ci[v]);
              ++numbers;
            } catch (const InputError&) {
            }
          }
          if (numbers > 0)
            fit.warnings.push_back("column '" + shown_text(v) + "' is taken as a factor: '" +
                                   shown_text(trim_blanks(t.rows[r][ci[v]])) + "' at line " +
                                   std::to_string(t.line[r]) + " is no number, though " +
                                   std::to_string(numbers) + " of its " + std::to_string(n) +
                                   " values used are (a typo, or a missing value not written "
                                   "NA?)");
        }
        break;
      }
    }
    if (!c.numeric || v == f.group) {
      c.numeric = false;
      c.num.clear();
      std::set<std::string> lv;
      for (int r : used) {
        c.level.push_back(trim_blanks(t.rows[r][ci[v]]));
        lv.insert(c.level.back());
      }
      c.levels.assign(lv.begin(), lv.end());  // byte order (R in the C locale)
    }
    cols[v] = c;
  }
  for (auto& term : f.terms)
    for (auto& v : term)
      if (!cols[v].numeric && cols[v].levels.size() < 2)
        throw InputError("column '" + v + "' is a factor with a single level ('" +
                             shown_text(cols[v].levels[0]) + "') in the rows used",
                         t.file);

  Model md;
  md.reml = reml;
  md.n = n;
  std::vector<std::string> names;
  std::vector<int> term_of;
  md.X = design(f.terms, cols, n, false, &names, &term_of);
  md.p = static_cast<int>(md.X.cols());
  // The model is fitted with equilibrated columns, X = X_s · diag(x_scale): beta = beta_s /
  // x_scale and V = V_s / (x_scale x_scale'), t, df, p and the F tests unchanged; the REML
  // criterion's log|X'V^-1 X| gains 2 Σ log x_scale.
  const VectorXd x_scale = equilibrate(md.X);
  Eigen::ColPivHouseholderQR<MatrixXd> qr(md.X);
  if (qr.rank() < md.p)
    throw InputError("the fixed-effects design is rank deficient (rank " +
                         std::to_string(qr.rank()) + " < " + std::to_string(md.p) +
                         " columns): some factor combinations are empty or columns are collinear",
                     t.file);
  md.y = Eigen::Map<const VectorXd>(cols[f.response].num.data(), n);
  // A response far from order 1 is fitted on the scale of a power of two near its largest
  // magnitude (exact: no digit changes) and the results scaled back at the end: a response of
  // order 1e100 (or 1e-100) squared beyond the doubles' range, and the fit lost its df and p
  // without a word. Within 2^-50..2^50 nothing is rescaled (the optimiser's stopping tests are
  // relative to the deviance, which rescaling shifts: ordinary data keep their fit to the bit).
  double y_scale = 1.0;
  // Below 1e-150 the variances, vcov and sums of squares the fit reports (squares of the
  // response's units) underflow a double and print as 0 beside finite SDs and F (review
  // 2026-12-06, fifth): refused as `stats` refuses such a column.
  if (const double ymax = md.y.cwiseAbs().maxCoeff(); ymax > 0 && ymax < 1e-150)
    throw InputError("column '" + f.response + "': the response's values are at most " +
                         format_g(ymax) +
                         " in magnitude: below 1e-150 the variances and sums of squares of the "
                         "fit underflow a double (they would be 0); rescale the column (e.g. "
                         "other units)",
                     t.file);
  if (const double ymax = md.y.cwiseAbs().maxCoeff();
      ymax > 0 && std::isfinite(ymax) && (ymax > 0x1p50 || ymax < 0x1p-50)) {
    y_scale = std::ldexp(1.0, std::ilogb(ymax));
    md.y /= y_scale;
  }
  const Column& gc = cols[f.group];
  md.m = static_cast<int>(gc.levels.size());
  std::map<std::string, int> gidx;
  for (int i = 0; i < md.m; ++i) gidx[gc.levels[i]] = i;
  for (int r = 0; r < n; ++r) md.g.push_back(gidx[gc.level[r]]);
  md.k = f.slope.empty() ? 1 : 2;
  md.Z.resize(n, md.k);
  md.Z.col(0).setOnes();
  if (md.k == 2) md.Z.col(1) = Eigen::Map<const VectorXd>(cols[f.slope].num.data(), n);
  if (md.m < 2)
    throw InputError("grouping factor '" + f.group + "' has fewer than 2 levels", t.file);
  if (md.m * md.k >= n)
    throw InputError("the number of random effects (" + std::to_string(md.m * md.k) +
                         ") must be smaller than the number of observations (" + std::to_string(n) +
                         "), as lme4 requires",
                     t.file);
  if (n <= md.p) throw InputError("more fixed effects than observations", t.file);
  md.ZtZ.assign(md.m, MatrixXd::Zero(md.k, md.k));
  md.ZtX.assign(md.m, MatrixXd::Zero(md.k, md.p));
  md.Zty.assign(md.m, VectorXd::Zero(md.k));
  for (int r = 0; r < n; ++r) {
    int gi = md.g[r];
    md.ZtZ[gi] += md.Z.row(r).transpose() * md.Z.row(r);
    md.ZtX[gi] += md.Z.row(r).transpose() * md.X.row(r);
    md.Zty[gi] += md.Z.row(r).transpose() * md.y(r);
  }
  md.XtX = md.X.transpose() * md.X;
  md.Xty = md.X.transpose() * md.y;
  {
    // Random effects the fixed effects already contain: when every level's column of Z (its
    // indicator, or the slope within it) lies in the span of X, e.g. a fixed factor that
    // recodes the grouping factor or has one level of it per value, the random-effect
    // variance and the fixed effects are not identifiable (the fit used to print df 0 and a
    // p of 1e-8). Residual of each column after projection on X, with an orthonormal basis of
    // X (stable: no normal equations).
    const MatrixXd Q = qr.householderQ() * MatrixXd::Identity(n, md.p);
    for (int c = 0; c < md.k; ++c) {
      std::vector<VectorXd> proj(md.m, VectorXd::Zero(md.p));
      std::vector<double> norm2(md.m, 0.0);
      for (int r = 0; r < n; ++r) {
        proj[md.g[r]] += md.Z(r, c) * Q.row(r).transpose();
        norm2[md.g[r]] += md.Z(r, c) * md.Z(r, c);
      }
      bool all_in_span = true;
      for (int i = 0; i < md.m && all_in_span; ++i)
        all_in_span = !(norm2[i] - proj[i].squaredNorm() > 1e-8 * norm2[i]);
      if (all_in_span)
        throw InputError(
            (c == 0 ? "the random intercepts of '" + f.group + "'"
                    : "the random slopes of '" + f.slope + "' within '" + f.group + "'") +
                " are fully determined by the fixed effects (a fixed term recodes '" + f.group +
                "' or has a separate level for each of its levels): the model is not "
                "identifiable; remove that term from the fixed effects",
            t.file);
    }
  }
  {
    // A response the fixed effects reproduce exactly (e.g. constant) leaves no variance to
    // split between participants and residual: the model is not estimable.
    const VectorXd resid = md.y - md.X * qr.solve(md.y);
    const double scale = std::max(md.y.cwiseAbs().maxCoeff(), 1e-300);
    if (!(resid.cwiseAbs().maxCoeff() > 1e-12 * scale))
      throw InputError("the response '" + f.response +
                           "' is fitted exactly by the fixed effects (e.g. it is constant): no "
                           "variance is left to estimate",
                       t.file);
  }

  // --- optimise theta (lme4's start: identity Lambda)
  std::vector<double> th0 = md.k == 1 ? std::vector<double>{1} : std::vector<double>{1, 0, 1};
  std::vector<double> lower =
      md.k == 1 ? std::vector<double>{0} : std::vector<double>{0, -HUGE_VAL, 0};
  auto obj = [&](const std::vector<double>& th) { return profiled(md, evaluate(md, th)); };
  double fbest = obj(th0);
  std::vector<double> th = th0;
  double step = 0.5;
  for (int restart = 0; restart < 30; ++restart) {
    double fnew;
    auto x = nelder_mead(obj, th, lower, step, &fnew);
    double moved = 0;
    for (size_t j = 0; j < x.size(); ++j)
      moved = std::max(moved, std::abs(x[j] - th[j]) / std::max(1.0, std::abs(th[j])));
    bool improved = fnew < fbest - 1e-14 * std::abs(fbest);
    if (fnew <= fbest) th = x, fbest = fnew;
    if (!improved && moved < 1e-9 && restart > 0) break;
    step = std::max(1e-4, std::min(0.5, 10 * moved));
  }
  // A variance on its bound: the simplex approaches a singular optimum without reaching it
  // (theta 1.2e-8 for a REML minimum at 0, reported as an SD of 3.5e-7 and no warning; review
  // 2026-12-07). A bounded element below lme4's isSingular tolerance is put on the bound where
  // that is no worse than the rounding of the deviance.
  for (std::size_t j = 0; j < th.size(); ++j)
    if (lower[j] == 0 && th[j] != 0 && std::abs(th[j]) < kSingularTol) {
      std::vector<double> at = th;
      at[j] = 0;
      const double f0 = obj(at);
      if (f0 <= fbest + 1e-12 * std::abs(fbest)) th = at, fbest = std::min(fbest, f0);
    }
  Eval e = evaluate(md, th);
  fit.deviance = profiled(md, e);
  if (reml) fit.deviance += 2 * x_scale.array().log().sum();
  fit.n = n;
  fit.p = md.p;
  fit.n_groups = md.m;
  fit.group = f.group;
  fit.slope = f.slope;
  fit.theta = th;
  fit.rows_used = n;
  const double s2 = e.r2 / (reml ? n - md.p : n);
  fit.sigma = std::sqrt(s2);
  fit.sd_intercept = fit.sigma * std::abs(th[0]);
  if (md.k == 2) {
    fit.sd_slope = fit.sigma * std::hypot(th[1], th[2]);
    fit.correlation = (th[0] == 0 || fit.sd_slope == 0)
                          ? std::numeric_limits<double>::quiet_NaN()
                          : th[0] * th[1] / (std::abs(th[0]) * std::hypot(th[1], th[2]));
  }
  // lme4's isSingular(): a diagonal element of the relative covariance factor below 1e-4.
  if (std::abs(th[0]) < kSingularTol || (md.k == 2 && std::abs(th[2]) < kSingularTol))
    fit.warnings.push_back(
        "singular fit: a random-effect variance or correlation is on the "
        "boundary of its range");
  // The other boundary: a response that hardly varies within the levels of the grouping factor
  // (a participant-level value repeated on each row, a measure a participant always scores the
  // same). Theta, the random-effect SD over the residual SD, grows without bound and the
  // penalised least squares lose precision as theta² (measured on a balanced one-way layout
  // against its closed form: df 5.0002 at theta 2e3, 5.08 at 2e4, 10.8 at 2e5, -4.2 at 2e7;
  // review 2026-12-06, fourth). Beyond 1e5 no number of the fit can be trusted.
  double theta_max = 0;
  for (double t : th) theta_max = std::max(theta_max, std::abs(t));
  if (theta_max > 1e5)
    throw InputError("the response '" + f.response + "' hardly varies within the levels of '" +
                         f.group + "' (the residual SD is " + format_g(1.0 / theta_max) +
                         " times the random-effect SD): the mixed model is degenerate and "
                         "cannot be fitted reliably; analyse one value per level of '" +
                         f.group + "' (e.g. their means with palplab stats) instead",
                     t.file);
  if (theta_max > 1e3)
    fit.warnings.push_back("the residual SD is " + format_g(1.0 / theta_max) +
                           " times the random-effect SD (the response hardly varies within the "
                           "levels of '" +
                           f.group +
                           "'): the fit loses precision as the square of that ratio; standard "
                           "errors and Satterthwaite df may be off by a few per cent");
  fit.n_par = md.p + static_cast<int>(th.size()) + 1;
  fit.loglik = -fit.deviance / 2;
  fit.aic = fit.deviance + 2 * fit.n_par;
  fit.bic = fit.deviance + std::log(static_cast<double>(n)) * fit.n_par;
  const MatrixXd V = s2 * e.Minv;
  fit.vcov.assign(md.p, std::vector<double>(md.p));
  for (int a = 0; a < md.p; ++a)
    for (int b = 0; b < md.p; ++b) fit.vcov[a][b] = V(a, b) / (x_scale(a) * x_scale(b));

  // --- Satterthwaite (lmerTest): A = 2 H^-1 over varpar = (theta, sigma)
  std::vector<double> vp = th;
  vp.push_back(fit.sigma);
  const size_t nv = vp.size();
  // Steps on the scale of each parameter: theta is relative to sigma (order 1), sigma absolute.
  auto hstep = [&](size_t j) { return 1e-2 * std::max(std::abs(vp[j]), j + 1 < nv ? 0.1 : 0.0); };
  MatrixXd H(nv, nv);
  for (size_t a = 0; a < nv; ++a)
    for (size_t b = a; b < nv; ++b) {
      auto central = [&](double s) {
        const double ha = s * hstep(a), hb = s * hstep(b);
        auto at = [&](double da, double db) {
          auto x = vp;
          x[a] += da;
          x[b] += db;
          return deviance_vp(md, x);
        };
        Eigen::Matrix<double, 1, 1> r;
        if (a == b)
          r(0) = (at(ha, 0) - 2 * at(0, 0) + at(-ha, 0)) / (ha * ha);
        else
          r(0) = (at(ha, hb) - at(ha, -hb) - at(-ha, hb) + at(-ha, -hb)) / (4 * ha * hb);
        return r;
      };
      H(a, b) = H(b, a) = richardson(central, 1.0)(0);
    }
  std::vector<MatrixXd> J(nv);
  for (size_t j = 0; j < nv; ++j) {
    auto central = [&](double s) {
      const double h = s * hstep(j);
      auto xp = vp, xm = vp;
      xp[j] += h;
      xm[j] -= h;
      return ((vcov_vp(md, xp) - vcov_vp(md, xm)) / (2 * h)).eval();
    };
    J[j] = richardson(central, 1.0);
  }
  Eigen::SelfAdjointEigenSolver<MatrixXd> hes(H);
  bool h_ok = hes.eigenvalues().minCoeff() > 0;
  if (!h_ok)
    fit.warnings.push_back(
        "the Hessian of the deviance w.r.t. the variance parameters is not "
        "positive definite: Satterthwaite df are unreliable");
  const MatrixXd A = 2 * H.inverse();
  bool df_undefined = false;
  auto satterthwaite = [&](const VectorXd& l) {
    VectorXd grad(nv);
    for (size_t j = 0; j < nv; ++j) grad(j) = l.dot(J[j] * l);
    const double v = l.dot(V * l);
    const double df = 2 * v * v / grad.dot(A * grad);
    // A df that is not positive is no df (a Hessian that is not positive definite gave -4.2):
    // no t or F test rather than a p from it.
    if (df > 0) return df;
    df_undefined = true;
    return std::numeric_limits<double>::quiet_NaN();
  };
  for (int j = 0; j < md.p; ++j) {
    LmmFixedEffect fe;
    fe.name = names[j];
    fe.estimate = e.beta(j) / x_scale(j);
    fe.se = std::sqrt(V(j, j)) / x_scale(j);
    fe.t = e.beta(j) / std::sqrt(V(j, j));
    fe.df = satterthwaite(VectorXd::Unit(md.p, j));
    fe.p = t_two_sided_p(fe.t, fe.df);
    fit.fixed.push_back(fe);
  }

  // --- type III tests: the hypotheses "term = 0" in the sum-coded parameterisation, mapped to
  // treatment coding (beta_sum = C beta_trt with C = X_sum^+ X_trt).
  std::vector<std::string> sum_names;
  std::vector<int> sum_term;
  MatrixXd Xs = design(f.terms, cols, n, true, &sum_names, &sum_term);
  equilibrate(Xs);  // rescales rows of C: the hypotheses (row spaces) stay the same
  MatrixXd C = Xs.colPivHouseholderQr().solve(md.X);
  for (size_t ti = 0; ti < f.terms.size(); ++ti) {
    std::vector<int> rowsL;
    for (int j = 0; j < md.p; ++j)
      if (sum_term[j] == static_cast<int>(ti)) rowsL.push_back(j);
    MatrixXd L(rowsL.size(), md.p);
    for (size_t r = 0; r < rowsL.size(); ++r) L.row(r) = C.row(rowsL[r]);
    for (int a = 0; a < L.rows(); ++a)
      for (int b = 0; b < L.cols(); ++b)
        if (std::abs(L(a, b)) < 1e-12 * L.cwiseAbs().maxCoeff()) L(a, b) = 0;
    LmmFTest ft;
    for (auto& v : f.terms[ti]) ft.term += (ft.term.empty() ? "" : ":") + v;
    const MatrixXd VL = L * V * L.transpose();
    Eigen::SelfAdjointEigenSolver<MatrixXd> es(VL);
    // eigenvalues descending, as R's eigen()
    const int q0 = static_cast<int>(VL.rows());
    std::vector<int> ord(q0);
    for (int i = 0; i < q0; ++i) ord[i] = q0 - 1 - i;
    const double dmax = es.eigenvalues()(q0 - 1);
    const double tol = std::max(std::sqrt(std::numeric_limits<double>::epsilon()) * dmax, 0.0);
    double t2sum = 0;
    std::vector<double> nu;
    for (int i : ord) {
      const double d = es.eigenvalues()(i);
      if (!(d > tol)) continue;
      VectorXd l = L.transpose() * es.eigenvectors().col(i);
      const double est = l.dot(e.beta);
      t2sum += est * est / d;
      nu.push_back(satterthwaite(l));
    }
    const int q = static_cast<int>(nu.size());
    ft.num_df = q;
    ft.f = q > 0 ? t2sum / q : std::numeric_limits<double>::quiet_NaN();
    if (q == 0) {
      // No estimable contrast (a zero covariance of the estimates): no test.
      ft.den_df = std::numeric_limits<double>::quiet_NaN();
    } else if (q == 1) {
      ft.den_df = nu[0];
    } else {
      bool same = true;
      for (double v : nu) same = same && std::abs(v - nu[0]) < 1e-8;
      if (same) {
        ft.den_df = nu[0];
      } else {
        bool small = false;
        double E = 0;
        for (double v : nu) {
          small = small || v <= 2;
          E += v / (v - 2);
        }
        ft.den_df = small ? 2 : 2 * E / (E - q);
      }
    }
    ft.p = f_upper_p(ft.f, q, ft.den_df);
    ft.mean_sq = ft.f * s2;
    ft.sum_sq = ft.mean_sq * q;
    if (std::isfinite(ft.f) && std::isfinite(ft.den_df) && ft.den_df > 0) {
      ft.partial_eta_squared = ft.f * q / (ft.f * q + ft.den_df);
      ft.partial_eta_squared_ci = f_effect_ci(ft.f, q, ft.den_df);
    }
    fit.anova.push_back(ft);
  }
  if (df_undefined)
    fit.warnings.push_back(
        "a Satterthwaite df came out not positive (the variance parameters' Hessian is not "
        "usable): its test is shown as n/a");
  // Back to the response's own scale (t, F, df, p and theta do not depend on it).
  if (y_scale != 1.0) {
    const double dof = reml ? n - md.p : n;
    fit.sigma *= y_scale;
    fit.sd_intercept *= y_scale;
    fit.sd_slope *= y_scale;
    fit.deviance += 2 * dof * std::log(y_scale);
    fit.loglik = -fit.deviance / 2;
    fit.aic = fit.deviance + 2 * fit.n_par;
    fit.bic = fit.deviance + std::log(static_cast<double>(n)) * fit.n_par;
    for (auto& row : fit.vcov)
      for (double& v : row) v *= y_scale * y_scale;
    for (auto& fe : fit.fixed) {
      fe.estimate *= y_scale;
      fe.se *= y_scale;
    }
    for (auto& ft : fit.anova) {
      ft.mean_sq *= y_scale * y_scale;
      ft.sum_sq *= y_scale * y_scale;
    }
  }
  return fit;
}

namespace {
// printf of one number into a string of the size needed (a 64-byte buffer cut large numbers
// printed with %f); "n/a" for NaN or infinity.
std::string fmt(const char* f, double v) {
  if (!std::isfinite(v)) return "n/a";
  const int n = std::snprintf(nullptr, 0, f, v);
  std::string out(n > 0 ? static_cast<size_t>(n) : 0, '\0');
  if (n > 0) std::snprintf(out.data(), out.size() + 1, f, v);
  return out;
}
// A statistic (t, F) with `decimals` decimals, from 1e6 on in scientific notation.
std::string stat(double v, int decimals) {
  if (!std::isfinite(v)) return "n/a";
  const int n = std::snprintf(nullptr, 0, std::fabs(v) < 1e6 ? "%.*f" : "%.*e", decimals, v);
  std::string out(static_cast<size_t>(std::max(n, 0)), '\0');
  std::snprintf(out.data(), out.size() + 1, std::fabs(v) < 1e6 ? "%.*f" : "%.*e", decimals, v);
  return out;
}
// Exact p even below 2.2e-16 (R prints "< 2e-16"); the t and F tails are relative-accurate.
std::string pfmt(double p) {
  return fmt("%.4g", p);
}
// Names from the input (columns, factor levels in term names): control characters escaped.
std::string esc(const std::string& s) {
  return escape_controls(s, false);
}
// Width on screen: characters, not bytes (a name "Größe" took 2 columns too many).
size_t width(const std::string& s) {
  return static_cast<size_t>(char_count(s));
}
std::string pad(std::string s, size_t w, bool left = false) {
  // A value wider than its column keeps a space from its neighbour ("7.28498e-2018.53521e-101"
  // ran two columns together: review 2026-12-06, fifth).
  const size_t n = width(s);
  if (n >= w) return left ? s + " " : " " + s;
  return left ? s + std::string(w - n, ' ') : std::string(w - n, ' ') + s;
}
}  // namespace

std::string to_text(const LmmFit& fit, const std::string& formula) {
  std::ostringstream o;
  o << "Linear mixed model fit by " << (fit.reml ? "REML" : "maximum likelihood")
    << ". t-tests use Satterthwaite's method\n";
  o << "Formula: " << esc(formula) << "\n\n";
  if (fit.reml) {
    o << "REML criterion at convergence: " << fmt("%.6f", fit.deviance) << "\n";
  } else {
    o << "logLik: " << fmt("%.6f", fit.loglik) << "   deviance: " << fmt("%.6f", fit.deviance)
      << "\n";
  }
  o << "AIC: " << fmt("%.4f", fit.aic) << "   BIC: " << fmt("%.4f", fit.bic)
    << "   (df = " << fit.n_par << ")\n\n";
  o << "Random effects:\n";
  const std::string group = esc(fit.group), slope = esc(fit.slope);
  const size_t gw = std::max<size_t>(9, width(group) + 2);
  o << " " << pad("Groups", gw, true) << pad("Name", 13, true) << pad("Variance", 14)
    << pad("Std.Dev.", 12) << (fit.slope.empty() ? "" : "   Corr") << "\n";
  o << " " << pad(group, gw, true) << pad("(Intercept)", 13, true)
    << pad(fmt("%.6g", fit.sd_intercept * fit.sd_intercept), 14)
    << pad(fmt("%.6g", fit.sd_intercept), 12) << "\n";
  if (!fit.slope.empty())
    o << " " << pad("", gw, true) << pad(slope, 13, true)
      << pad(fmt("%.6g", fit.sd_slope * fit.sd_slope), 14) << pad(fmt("%.6g", fit.sd_slope), 12)
      << "   " << fmt("%.4f", fit.correlation) << "\n";
  o << " " << pad("Residual", gw, true) << pad("", 13, true)
    << pad(fmt("%.6g", fit.sigma * fit.sigma), 14) << pad(fmt("%.6g", fit.sigma), 12) << "\n";
  o << "Number of obs: " << fit.n << ", groups:  " << group << ", " << fit.n_groups;
  if (fit.rows_dropped_na > 0) o << " (" << fit.rows_dropped_na << " rows with NA dropped)";
  o << "\n\nFixed effects:\n";
  size_t nw = 12;
  for (auto& fe : fit.fixed) nw = std::max(nw, width(esc(fe.name)) + 2);
  o << pad("", nw, true) << pad("Estimate", 14) << pad("Std. Error", 13) << pad("df", 11)
    << pad("t value", 10) << pad("Pr(>|t|)", 12) << "\n";
  for (auto& fe : fit.fixed)
    o << pad(esc(fe.name), nw, true) << pad(fmt("%.6g", fe.estimate), 14)
      << pad(fmt("%.6g", fe.se), 13) << pad(fmt("%.3f", fe.df), 11) << pad(stat(fe.t, 3), 10)
      << pad(pfmt(fe.p), 12) << "\n";
  if (!fit.anova.empty()) {
    o << "\nType III Analysis of Variance Table with Satterthwaite's method\n";
    size_t tw = 8;
    for (auto& a : fit.anova) tw = std::max(tw, width(esc(a.term)) + 2);
    o << pad("", tw, true) << pad("Sum Sq", 12) << pad("Mean Sq", 12) << pad("NumDF", 6)
      << pad("DenDF", 10) << pad("F value", 10) << pad("Pr(>F)", 12) << "\n";
    for (auto& a : fit.anova)
      o << pad(esc(a.term), tw, true) << pad(fmt("%.6g", a.sum_sq), 12)
        << pad(fmt("%.6g", a.mean_sq), 12) << pad(std::to_string(a.num_df), 6)
        << pad(fmt("%.3f", a.den_df), 10) << pad(stat(a.f, 4), 10) << pad(pfmt(a.p), 12) << "\n";
    o << "\nPartial eta^2 [95% CI, noncentral F with the Satterthwaite df]\n";
    for (auto& a : fit.anova)
      if (a.partial_eta_squared_ci.defined)
        o << pad(esc(a.term), tw, true) << fmt("%.3f", a.partial_eta_squared) << " ["
          << fmt("%.3f", a.partial_eta_squared_ci.pve_low) << ", "
          << fmt("%.3f", a.partial_eta_squared_ci.pve_high) << "]\n";
  }
  for (auto& w : fit.warnings) o << "\nwarning: " << w << "\n";
  return o.str();
}

nlohmann::json to_json(const LmmFit& fit) {
  using nlohmann::json;
  auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json j;
  j["method"] = fit.reml ? "REML" : "ML";
  j["n_obs"] = fit.n;
  j["n_groups"] = fit.n_groups;
  j["rows_dropped_na"] = fit.rows_dropped_na;
  if (fit.reml)
    j["reml_criterion"] = fit.deviance;
  else
    j["deviance"] = fit.deviance;
  j["loglik"] = fit.loglik;
  j["df"] = fit.n_par;
  j["aic"] = fit.aic;
  j["bic"] = fit.bic;
  j["sigma"] = fit.sigma;
  j["theta"] = fit.theta;
  json re = {{"group", fit.group}, {"sd_intercept", fit.sd_intercept}};
  if (!fit.slope.empty()) {
    re["slope"] = fit.slope;
    re["sd_slope"] = fit.sd_slope;
    re["correlation"] = num(fit.correlation);
  }
  re["sd_residual"] = fit.sigma;
  j["random_effects"] = re;
  json fx = json::array();
  for (auto& fe : fit.fixed)
    fx.push_back({{"term", fe.name},
                  {"estimate", fe.estimate},
                  {"se", fe.se},
                  {"df", num(fe.df)},
                  {"t", fe.t},
                  {"p", num(fe.p)}});
  j["fixed_effects"] = fx;
  j["vcov"] = fit.vcov;
  json an = json::array();
  for (auto& a : fit.anova)
    an.push_back({{"term", a.term},
                  {"sum_sq", a.sum_sq},
                  {"mean_sq", a.mean_sq},
                  {"num_df", a.num_df},
                  {"den_df", num(a.den_df)},
                  {"f", a.f},
                  {"p", num(a.p)},
                  {"partial_eta_squared", num(a.partial_eta_squared)}});
  for (size_t i = 0; i < fit.anova.size(); ++i)
    if (const auto& c = fit.anova[i].partial_eta_squared_ci; c.defined)
      an[i]["partial_eta_squared_ci"] = {num(c.pve_low), num(c.pve_high)};
  j["anova"] = an;
  j["warnings"] = fit.warnings;
  return j;
}

}  // namespace palplab::analysis
