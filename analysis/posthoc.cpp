#include "analysis/posthoc.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "analysis/descriptives.hpp"
#include "analysis/distributions.hpp"
#include "analysis/parallel.hpp"
#include "common/nan.hpp"

namespace palplab::analysis {

namespace {}

std::vector<double> bonferroni(const std::vector<double>& p, std::vector<bool>* is_bound) {
  size_t m = 0;
  for (double v : p) m += !std::isnan(v);
  std::vector<double> r(p.size());
  if (is_bound) is_bound->assign(p.size(), false);
  for (size_t i = 0; i < p.size(); ++i) {
    r[i] = std::isnan(p[i]) ? kNaN : std::min(1.0, m * p[i]);
    if (is_bound) (*is_bound)[i] = p_is_bound(p[i]) && r[i] < 1;
  }
  return r;
}

std::vector<double> holm(const std::vector<double>& p, std::vector<bool>* is_bound) {
  std::vector<size_t> idx;
  for (size_t i = 0; i < p.size(); ++i)
    if (!std::isnan(p[i])) idx.push_back(i);
  std::stable_sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return p[a] < p[b]; });
  const size_t m = idx.size();
  std::vector<double> r(p.size(), kNaN);
  if (is_bound) is_bound->assign(p.size(), false);
  double running = 0;
  bool running_bound = false;  // the running maximum is only known as an upper bound
  for (size_t j = 0; j < m; ++j) {
    const double term = std::min(1.0, (m - j) * p[idx[j]]);
    const bool term_bound = p_is_bound(p[idx[j]]) && term < 1;
    if (term > running) {
      running = term;
      running_bound = term_bound;
    } else if (term == running) {
      running_bound = running_bound && term_bound;  // an exact term of the same value: exact
    }
    r[idx[j]] = running;
    if (is_bound) (*is_bound)[idx[j]] = running_bound;
  }
  return r;
}

std::vector<PairwiseT> pairwise_t(const Groups& groups, bool welch, DfMode mode) {
  std::vector<PairwiseT> out;
  for (size_t a = 0; a < groups.size(); ++a)
    for (size_t b = a + 1; b < groups.size(); ++b) {
      PairwiseT r;
      r.a = static_cast<int>(a);
      r.b = static_cast<int>(b);
      out.push_back(r);
    }
  parallel_for(out.size(), [&](size_t i) {
    PairwiseT& r = out[i];
    const auto &ga = groups[r.a], &gb = groups[r.b];
    r.test = welch ? welch_t(ga, gb, mode) : student_t(ga, gb);
    // The effect-size interval inverts the same t as the test beside it.
    r.effect = welch ? cohens_d_welch(ga, gb, r.test) : cohens_d(ga, gb);
  });
  std::vector<double> p;
  for (auto& r : out) p.push_back(r.test.p);
  std::vector<bool> h_bound, bf_bound;
  auto h = holm(p, &h_bound), bf = bonferroni(p, &bf_bound);
  for (size_t i = 0; i < out.size(); ++i) {
    out[i].p_holm = h[i];
    out[i].p_bonferroni = bf[i];
    out[i].p_holm_is_bound = h_bound[i];
    out[i].p_bonferroni_is_bound = bf_bound[i];
  }
  return out;
}

RangeQuantiles::RangeQuantiles(double level, int k, const std::vector<double>& dfs)
    : level_(level), k_(k) {
  std::vector<double> small, big;
  for (double v : dfs)
    if (v > 0 && std::isfinite(v)) (v < kSmallDf ? small : big).push_back(v);
  for (auto* v : {&small, &big}) {
    std::sort(v->begin(), v->end());
    v->erase(std::unique(v->begin(), v->end()), v->end());
  }
  cover(small, true);
  cover(big, false);
  std::sort(direct_df_.begin(), direct_df_.end());
  direct_q_.resize(direct_df_.size());
  parallel_for(
      direct_df_.size(),
      [&](size_t i) { direct_q_[i] = studentized_range_quantile(level, k, direct_df_[i]); }, 2);
}

void RangeQuantiles::cover(const std::vector<double>& dfs, bool log_q) {
  if (dfs.size() <= kDirectMax) {
    direct_df_.insert(direct_df_.end(), dfs.begin(), dfs.end());
    return;
  }
  // Interpolate in x = 1/ν on Chebyshev points of the second kind (barycentric form): q(x) (and
  // log q(x)) is analytic there, so the error falls geometrically with the number of nodes. The
  // error is measured at the df of three pairs between nodes; more nodes when it is above
  // kInterpolationTol, all pairs directly if even kMaxNodes do not reach it.
  Piece pc;
  pc.log_q = log_q;
  pc.x_lo = 1 / dfs.back();
  pc.x_hi = 1 / dfs.front();
  const double checks[] = {dfs[dfs.size() / 3], dfs[dfs.size() / 2], dfs[2 * dfs.size() / 3]};
  double exact[3];
  parallel_for(
      3, [&](size_t c) { exact[c] = studentized_range_quantile(level_, k_, checks[c]); }, 2);
  // A narrow df range (e.g. Welch df that differ only by rounding) needs 2 or 3 nodes.
  const int first = pc.x_hi - pc.x_lo < 1e-3 * pc.x_hi ? 2 : 9;
  for (int n = first; n <= kMaxNodes; n = 2 * n - 1) {
    std::vector<double> x(n), q(n);
    for (int i = 0; i < n; ++i)
      x[i] = 0.5 * (pc.x_lo + pc.x_hi) + 0.5 * (pc.x_hi - pc.x_lo) * std::cos(M_PI * i / (n - 1));
    parallel_for(
        n,
        [&](size_t i) {
          const double v = studentized_range_quantile(level_, k_, 1 / x[i]);
          q[i] = log_q ? std::log(v) : v;
        },
        2);
    pc.nodes = x;
    pc.values = q;
    double worst = 0;
    for (int c = 0; c < 3; ++c)
      worst = std::max(worst, std::fabs(pc(1 / checks[c]) - exact[c]) / exact[c]);
    if (worst <= kInterpolationTol) {
      pieces_.push_back(std::move(pc));
      return;
    }
  }
  direct_df_.insert(direct_df_.end(), dfs.begin(), dfs.end());
}

double RangeQuantiles::Piece::operator()(double x) const {
  // Barycentric weights of Chebyshev points of the second kind: (-1)^i, halved at the ends.
  const size_t n = nodes.size();
  double num = 0, den = 0;
  for (size_t i = 0; i < n; ++i) {
    double d = x - nodes[i];
    if (d == 0) return log_q ? std::exp(values[i]) : values[i];
    double w = (i % 2 ? -1.0 : 1.0) * (i == 0 || i + 1 == n ? 0.5 : 1.0) / d;
    num += w * values[i];
    den += w;
  }
  return log_q ? std::exp(num / den) : num / den;
}

double RangeQuantiles::operator()(double df) const {
  auto it = std::lower_bound(direct_df_.begin(), direct_df_.end(), df);
  if (it != direct_df_.end() && *it == df) return direct_q_[it - direct_df_.begin()];
  const double x = 1 / df;
  for (const Piece& pc : pieces_)
    if (x >= pc.x_lo && x <= pc.x_hi) return pc(x);
  return studentized_range_quantile(level_, k_, df);
}

namespace {
void finish_range(RangeComparison& r, int k, const RangeQuantiles& qc) {
  if (!(r.se > 0) || !(r.df > 0)) {
    r.defined = false;
    r.q = r.p = r.ci_low = r.ci_high = kNaN;
    return;
  }
  r.q = std::fabs(r.mean_diff) / r.se;
  r.p = clamp_p(studentized_range_sf(r.q, k, r.df));
  const double c = qc(r.df);
  r.ci_low = r.mean_diff - c * r.se;
  r.ci_high = r.mean_diff + c * r.se;
}
}  // namespace

std::vector<RangeComparison> tukey_kramer(const Groups& groups, double level) {
  Anova an = oneway_anova(groups);
  const int k = static_cast<int>(groups.size());
  std::vector<RangeComparison> out;
  // MS_within in long double: spreads of ~1e-162 square below the double range, and a pair's
  // se (~1e-162, a double) came out 0, its q, p and interval undefined beside an ANOVA p below
  // 1e-300 (review of the fixes, 2026-12-07). Every pair's se from it (the same digits as the
  // double MS to a double's rounding where that one is in range).
  long double ss = 0;
  for (const auto& g : groups) ss += sum_sq_dev(g);
  const long double ms = an.df_within > 0 ? ss / an.df_within : 0.0L;
  double qc = ms > 0 ? studentized_range_quantile(level, k, an.df_within) : kNaN;
  for (int a = 0; a < k; ++a)
    for (int b = a + 1; b < k; ++b) {
      RangeComparison r;
      r.a = a;
      r.b = b;
      out.push_back(r);
    }
  parallel_for(out.size(), [&](size_t i) {
    RangeComparison& r = out[i];
    const auto &ga = groups[r.a], &gb = groups[r.b];
    r.mean_diff = static_cast<double>(mean_ld(ga) - mean_ld(gb));
    r.df = an.df_within;
    r.se = static_cast<double>(std::sqrt(ms / 2 * (1.0L / ga.size() + 1.0L / gb.size())));
    if (r.se > 0) {
      r.q = std::fabs(r.mean_diff) / r.se;
      r.p = clamp_p(studentized_range_sf(r.q, k, r.df));
      r.ci_low = r.mean_diff - qc * r.se;
      r.ci_high = r.mean_diff + qc * r.se;
    } else {
      r.defined = false;
      r.q = r.p = r.ci_low = r.ci_high = kNaN;
    }
  });
  return out;
}

std::vector<RangeComparison> games_howell(const Groups& groups, double level) {
  const int k = static_cast<int>(groups.size());
  std::vector<RangeComparison> out;
  std::vector<double> dfs;
  for (int a = 0; a < k; ++a)
    for (int b = a + 1; b < k; ++b) {
      RangeComparison r;
      r.a = a;
      r.b = b;
      out.push_back(r);
    }
  parallel_for(out.size(), [&](size_t i) {
    RangeComparison& r = out[i];
    const TTest w = welch_t_moments(groups[r.a], groups[r.b]);
    r.mean_diff = w.mean_diff;
    r.se = w.se / std::sqrt(2.0);
    r.df = w.df_exact;
  });
  for (const auto& r : out)
    if (r.se > 0 && r.df > 0) dfs.push_back(r.df);
  // One critical value per pair's df, but not one slow root search per pair.
  RangeQuantiles qc(level, k, dfs);
  parallel_for(out.size(), [&](size_t i) { finish_range(out[i], k, qc); });
  return out;
}

}  // namespace palplab::analysis
