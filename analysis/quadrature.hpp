#pragma once
// Adaptive Gauss–Legendre quadrature in long double, used by the studentized range and the
// noncentral t distributions. Each interval is integrated with a 15-point rule and with the
// same rule on its two halves; the halves are accepted when they agree with the whole to the
// interval's share of the absolute tolerance, else each half is refined. The tolerance is set
// relative to a first estimate of the whole integral, so relative accuracy holds even when
// the integral is tiny (lower tails of 1e-24).
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace palplab::analysis {

// Nodes (on [-1, 1]) and weights of the n-point Gauss–Legendre rule, by Newton's method on the
// Legendre recurrence in long double.
template <int N>
struct GaussLegendre {
  std::array<long double, N> x{}, w{};
  GaussLegendre() {
    const long double pi = 3.141592653589793238462643383279502884L;
    for (int i = 0; i < N; ++i) {
      long double z = std::cos(pi * (i + 0.75L) / (N + 0.5L));
      long double dp = 0;
      for (int it = 0; it < 100; ++it) {
        long double p0 = 1, p1 = z;
        for (int j = 2; j <= N; ++j) {
          long double p2 = ((2 * j - 1) * z * p1 - (j - 1) * p0) / j;
          p0 = p1;
          p1 = p2;
        }
        dp = N * (z * p1 - p0) / (z * z - 1);
        long double dz = p1 / dp;
        z -= dz;
        if (std::fabs(dz) < 1e-21L) break;
      }
      long double p0 = 1, p1 = z;
      for (int j = 2; j <= N; ++j) {
        long double p2 = ((2 * j - 1) * z * p1 - (j - 1) * p0) / j;
        p0 = p1;
        p1 = p2;
      }
      dp = N * (z * p1 - p0) / (z * z - 1);
      x[i] = z;
      w[i] = 2 / ((1 - z * z) * dp * dp);
    }
  }
};

inline const GaussLegendre<15>& gauss_legendre15() {
  static const GaussLegendre<15> rule;
  return rule;
}

template <class F>
long double gauss_legendre_fixed(const F& f, long double a, long double b) {
  const auto& g = gauss_legendre15();
  long double c = 0.5L * (a + b), h = 0.5L * (b - a), s = 0;
  for (int i = 0; i < 15; ++i) s += g.w[i] * f(c + h * g.x[i]);
  return s * h;
}

namespace detail {
// `budget` caps the number of interval evaluations so a tolerance below the rounding noise
// cannot recurse without end; the roundoff floor is a few double ulps of the piece itself (the
// integrands are accurate to double precision, so agreement beyond that is noise).
template <class F>
long double adapt(const F& f, long double a, long double b, long double whole,
                  long double tol_per_length, int depth, long& budget) {
  long double m = 0.5L * (a + b);
  long double l = gauss_legendre_fixed(f, a, m), r = gauss_legendre_fixed(f, m, b);
  long double both = l + r;
  budget -= 2;
  long double err = std::fabs(both - whole);
  if (depth <= 0 || budget <= 0 || err <= tol_per_length * (b - a) ||
      err <= 16 * 2.220446e-16L * std::fabs(both) || !(m > a && m < b))
    return both;
  return adapt(f, a, m, l, tol_per_length, depth - 1, budget) +
         adapt(f, m, b, r, tol_per_length, depth - 1, budget);
}
}  // namespace detail

// ∫ f over the pieces [p0,p1], [p1,p2], ... of the sorted breakpoints `pts`, to relative
// accuracy `rel_tol` of the total (or `abs_tol`, whichever is larger).
// `max_refinements` bounds the work (each refinement costs 30 evaluations of f).
template <class F>
long double integrate(const F& f, std::vector<long double> pts, long double rel_tol,
                      long double abs_tol = 0, long max_refinements = 1000) {
  std::sort(pts.begin(), pts.end());
  pts.erase(std::unique(pts.begin(), pts.end()), pts.end());
  if (pts.size() < 2) return 0;
  // First estimate: one rule per piece (the breakpoints put narrow peaks inside pieces).
  std::vector<long double> fine = pts, est;
  long double total = 0;
  for (size_t i = 0; i + 1 < fine.size(); ++i) {
    est.push_back(gauss_legendre_fixed(f, fine[i], fine[i + 1]));
    total += est.back();
  }
  long double tol = std::max(abs_tol, rel_tol * std::fabs(total));
  long double len = fine.back() - fine.front();
  if (tol == 0) return 0;  // the integrand vanishes at every node of the first estimate
  long double sum = 0;
  long budget = 2 * max_refinements;
  for (size_t i = 0; i + 1 < fine.size(); ++i)
    sum += detail::adapt(f, fine[i], fine[i + 1], est[i], tol / len, 50, budget);
  return sum;
}

}  // namespace palplab::analysis
