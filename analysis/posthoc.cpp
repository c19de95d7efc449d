#include "analysis/posthoc.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "analysis/descriptives.hpp"
#include "analysis/distributions.hpp"

namespace palplab::analysis {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}

std::vector<double> bonferroni(const std::vector<double>& p) {
  size_t m = 0;
  for (double v : p) m += !std::isnan(v);
  std::vector<double> r(p.size());
  for (size_t i = 0; i < p.size(); ++i) r[i] = std::isnan(p[i]) ? kNaN : std::min(1.0, m * p[i]);
  return r;
}

std::vector<double> holm(const std::vector<double>& p) {
  std::vector<size_t> idx;
  for (size_t i = 0; i < p.size(); ++i)
    if (!std::isnan(p[i])) idx.push_back(i);
  std::stable_sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return p[a] < p[b]; });
  const size_t m = idx.size();
  std::vector<double> r(p.size(), kNaN);
  double running = 0;
  for (size_t j = 0; j < m; ++j) {
    running = std::max(running, std::min(1.0, (m - j) * p[idx[j]]));
    r[idx[j]] = running;
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
      r.test = welch ? welch_t(groups[a], groups[b], mode) : student_t(groups[a], groups[b]);
      r.effect = cohens_d(groups[a], groups[b]);
      out.push_back(r);
    }
  std::vector<double> p;
  for (auto& r : out) p.push_back(r.test.p);
  auto h = holm(p), bf = bonferroni(p);
  for (size_t i = 0; i < out.size(); ++i) {
    out[i].p_holm = h[i];
    out[i].p_bonferroni = bf[i];
  }
  return out;
}

namespace {
void finish_range(RangeComparison& r, int k, double level) {
  if (!(r.se > 0) || !(r.df > 0)) {
    r.defined = false;
    r.q = r.p = r.ci_low = r.ci_high = kNaN;
    return;
  }
  r.q = std::fabs(r.mean_diff) / r.se;
  r.p = clamp_p(studentized_range_sf(r.q, k, r.df));
  double qc = studentized_range_quantile(level, k, r.df);
  r.ci_low = r.mean_diff - qc * r.se;
  r.ci_high = r.mean_diff + qc * r.se;
}
}  // namespace

std::vector<RangeComparison> tukey_kramer(const Groups& groups, double level) {
  Anova an = oneway_anova(groups);
  const int k = static_cast<int>(groups.size());
  std::vector<RangeComparison> out;
  double qc = an.ms_within > 0 ? studentized_range_quantile(level, k, an.df_within) : kNaN;
  for (int a = 0; a < k; ++a)
    for (int b = a + 1; b < k; ++b) {
      RangeComparison r;
      r.a = a;
      r.b = b;
      r.mean_diff = static_cast<double>(mean_ld(groups[a]) - mean_ld(groups[b]));
      r.df = an.df_within;
      r.se = std::sqrt(an.ms_within / 2 * (1.0 / groups[a].size() + 1.0 / groups[b].size()));
      if (r.se > 0) {
        r.q = std::fabs(r.mean_diff) / r.se;
        r.p = clamp_p(studentized_range_sf(r.q, k, r.df));
        r.ci_low = r.mean_diff - qc * r.se;
        r.ci_high = r.mean_diff + qc * r.se;
      } else {
        r.defined = false;
        r.q = r.p = r.ci_low = r.ci_high = kNaN;
      }
      out.push_back(r);
    }
  return out;
}

std::vector<RangeComparison> games_howell(const Groups& groups, double level) {
  const int k = static_cast<int>(groups.size());
  std::vector<RangeComparison> out;
  for (int a = 0; a < k; ++a)
    for (int b = a + 1; b < k; ++b) {
      RangeComparison r;
      r.a = a;
      r.b = b;
      TTest w = welch_t(groups[a], groups[b]);
      r.mean_diff = w.mean_diff;
      r.se = w.se / std::sqrt(2.0);
      r.df = w.df_exact;
      finish_range(r, k, level);
      out.push_back(r);
    }
  return out;
}

}  // namespace palplab::analysis
