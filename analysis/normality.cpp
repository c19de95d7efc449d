#include "analysis/normality.hpp"

#include <gsl/gsl_cdf.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "analysis/distributions.hpp"

namespace palplab::analysis {

namespace {
// c[0] + c[1] x + ... + c[n-1] x^(n-1)
double poly(const double* c, int n, double x) {
  double r = 0;
  for (int i = n - 1; i >= 0; --i) r = r * x + c[i];
  return r;
}
}  // namespace

ShapiroWilk shapiro_wilk(std::vector<double> x) {
  gsl_quiet();
  const int n = static_cast<int>(x.size());
  if (n < 3 || n > 5000) throw std::invalid_argument("Shapiro-Wilk needs 3 to 5000 values");
  std::sort(x.begin(), x.end());
  ShapiroWilk r;
  const double range = x.back() - x.front();
  if (!(range > 0)) {
    r.defined = false;
    r.W = r.p = std::numeric_limits<double>::quiet_NaN();
    return r;
  }
  // Coefficients a_1..a_{n/2} (Royston 1992/1995): normal scores m_i, then polynomial
  // corrections of the two largest in 1/sqrt(n), the rest rescaled so Σa² = 1/2 per half.
  const int nn2 = n / 2;
  std::vector<double> a(nn2 + 1);  // 1-based
  if (n == 3) {
    a[1] = std::sqrt(0.5);
  } else {
    static const double c1[6] = {0.0, 0.221157, -0.147981, -2.071190, 4.434685, -2.706056};
    static const double c2[6] = {0.0, 0.042981, -0.293762, -1.752461, 5.682633, -3.582633};
    std::vector<double> m(nn2 + 1);
    double summ2 = 0;
    for (int i = 1; i <= nn2; ++i) {
      m[i] = gsl_cdf_ugaussian_Pinv((i - 0.375) / (n + 0.25));
      summ2 += m[i] * m[i];
    }
    summ2 *= 2;
    const double ssumm2 = std::sqrt(summ2), rsn = 1 / std::sqrt(static_cast<double>(n));
    const double a1 = poly(c1, 6, rsn) - m[1] / ssumm2;
    int i1;
    double fac;
    if (n > 5) {
      i1 = 3;
      const double a2 = -m[2] / ssumm2 + poly(c2, 6, rsn);
      fac =
          std::sqrt((summ2 - 2 * m[1] * m[1] - 2 * m[2] * m[2]) / (1 - 2 * a1 * a1 - 2 * a2 * a2));
      a[2] = a2;
    } else {
      i1 = 2;
      fac = std::sqrt((summ2 - 2 * m[1] * m[1]) / (1 - 2 * a1 * a1));
    }
    a[1] = a1;
    for (int i = i1; i <= nn2; ++i) a[i] = -m[i] / fac;
  }
  // W as the squared correlation of the order statistics with the antisymmetric coefficient
  // vector, 1 - W formed as (√(ssa·ssx) - sax)(√(ssa·ssx) + sax)/(ssa·ssx) so W near 1 keeps
  // its digits (as in AS R94).
  auto coef = [&](int i) {  // 0-based order statistic i -> signed coefficient
    int j = n - 1 - i;
    if (i == j) return 0.0;
    return i < j ? -a[i + 1] : a[j + 1];
  };
  long double sa = 0, sx = 0;
  for (int i = 0; i < n; ++i) {
    sa += coef(i);
    sx += x[i] / range;
  }
  sa /= n;
  sx /= n;
  long double ssa = 0, ssx = 0, sax = 0;
  for (int i = 0; i < n; ++i) {
    long double asa = coef(i) - sa, xsx = x[i] / range - sx;
    ssa += asa * asa;
    ssx += xsx * xsx;
    sax += asa * xsx;
  }
  const long double ssassx = std::sqrt(ssa * ssx);
  const double w1 = static_cast<double>((ssassx - sax) * (ssassx + sax) / (ssa * ssx));
  r.W = 1 - w1;
  if (n == 3) {
    const double pi6 = 6 / M_PI, stqr = M_PI / 3;  // asin(sqrt(3/4)) = π/3
    r.p = std::max(0.0, pi6 * (std::asin(std::sqrt(r.W)) - stqr));
    r.p = clamp_p(r.p);
    return r;
  }
  const double y = std::log(w1), lx = std::log(static_cast<double>(n));
  double mu, sigma, yy;
  if (n <= 11) {
    static const double g[2] = {-2.273, 0.459};
    static const double c3[4] = {0.5440, -0.39978, 0.025054, -6.714e-4};
    static const double c4[4] = {1.3822, -0.77857, 0.062767, -0.0020322};
    const double gamma = poly(g, 2, n);
    if (y >= gamma) {  // W below the approximation's range: AS R94 (and R) report 1e-99
      r.p = 1e-99;
      return r;
    }
    yy = -std::log(gamma - y);
    mu = poly(c3, 4, n);
    sigma = std::exp(poly(c4, 4, n));
  } else {
    static const double c5[4] = {-1.5861, -0.31082, -0.083751, 0.0038915};
    static const double c6[3] = {-0.4803, -0.082676, 0.0030302};
    yy = y;
    mu = poly(c5, 4, lx);
    sigma = std::exp(poly(c6, 3, lx));
  }
  r.p = clamp_p(gsl_cdf_ugaussian_Q((yy - mu) / sigma));
  return r;
}

}  // namespace palplab::analysis
