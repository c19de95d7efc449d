// The calibration's optimiser and its --bounds parsing, without a simulation (the command end to
// end: tests/cli_calibrate).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "common/input_error.hpp"
#include "protocols/calibrate.hpp"

using palplab::protocols::nelder_mead;
using palplab::protocols::parse_bound;
using palplab::protocols::quadratic_se;

TEST(NelderMead, FindsTheMinimumOfAQuadraticInsideTheBox) {
  auto f = [](const std::vector<double>& x) {
    return std::pow(x[0] - 0.3, 2) + 4 * std::pow(x[1] + 0.2, 2);
  };
  const auto r = nelder_mead(f, {1.0, 1.0}, {0.25, 0.25}, {-2, -2}, {2, 2}, 200);
  EXPECT_NEAR(r.x[0], 0.3, 2e-3);
  EXPECT_NEAR(r.x[1], -0.2, 2e-3);
  EXPECT_LE(r.evaluations, 200);
  EXPECT_TRUE(r.converged);
  // Never more evaluations than the budget, whichever step the budget ends in (a contraction
  // after the reflection that used it up made 13 of 12; review 2026-12-07).
  for (int budget = 1; budget <= 40; ++budget) {
    int calls = 0;
    const auto counted = [&](const std::vector<double>& x) { return ++calls, f(x); };
    const auto b = nelder_mead(counted, {1.0, 1.0}, {0.25, 0.25}, {-2, -2}, {2, 2}, budget);
    EXPECT_LE(calls, budget) << "budget " << budget;
    EXPECT_EQ(b.evaluations, calls);
  }
  // Stopped by its budget while the loss still falls: said (calibrate printed it like a fit).
  const auto cut = nelder_mead(f, {1.0, 1.0}, {0.25, 0.25}, {-2, -2}, {2, 2}, 8);
  EXPECT_EQ(cut.evaluations, 8);
  EXPECT_FALSE(cut.converged);
  EXPECT_GT(cut.f, r.f + 1e-3);
}

// A start on its upper bound: the first simplex step goes down (before, the step up was cut back
// onto the start, its loss equal, and the search ended "converged" at the start).
TEST(NelderMead, AStartOnItsUpperBoundMoves) {
  auto f = [](const std::vector<double>& x) { return std::pow(x[0] - 0.5, 2); };
  const auto r = nelder_mead(f, {1.0}, {0.25}, {0.0}, {1.0}, 60);
  EXPECT_NEAR(r.x[0], 0.5, 1e-3);
  // The minimum outside the box: the search ends on the nearer bound, never beyond it.
  auto g = [](const std::vector<double>& x) { return std::pow(x[0] - 3.0, 2); };
  const auto b = nelder_mead(g, {0.5}, {0.25}, {0.0}, {1.0}, 60);
  EXPECT_DOUBLE_EQ(b.x[0], 1.0);
}

// A loss that is −2 log L of a Gaussian, f = (x − μ)ᵀ Σ⁻¹ (x − μ) + c: its SEs are sqrt(diag Σ)
// exactly, from any set of points that determines the quadratic (here a 3×3 grid around a
// centre that is not μ, plus two more points), in coordinates of very different scales.
TEST(QuadraticSe, AGaussianLossGivesItsCovariance) {
  const double s0 = 0.004, s1 = 30.0, rho = 0.6;  // SDs (m and s, say) and correlation
  const double m0 = 0.006, m1 = 40.0;
  const double det = s0 * s0 * s1 * s1 * (1 - rho * rho);
  const double i00 = s1 * s1 / det, i11 = s0 * s0 / det, i01 = -rho * s0 * s1 / det;
  auto f = [&](double a, double b) {
    const double u = a - m0, v = b - m1;
    return i00 * u * u + 2 * i01 * u * v + i11 * v * v + 7.5;
  };
  std::vector<std::vector<double>> x;
  std::vector<double> y;
  for (int i = -1; i <= 1; ++i)
    for (int j = -1; j <= 1; ++j) {
      x.push_back({0.005 + i * 0.002, 45.0 + j * 10.0});
      y.push_back(f(x.back()[0], x.back()[1]));
    }
  x.push_back({0.009, 20.0});
  y.push_back(f(0.009, 20.0));
  const auto se = quadratic_se(x, y, {0.005, 45.0}, {0.001, 10.0}, {true, true});
  ASSERT_EQ(se.size(), 2u);
  EXPECT_NEAR(se[0], s0, 1e-9 * s0);
  EXPECT_NEAR(se[1], s1, 1e-9 * s1);
  // One coordinate held (on its bound): the other's SE is conditional on it, 1/sqrt((Σ⁻¹)_ii).
  const auto held = quadratic_se(x, y, {0.005, 45.0}, {0.001, 10.0}, {false, true});
  EXPECT_TRUE(std::isnan(held[0]));
  EXPECT_NEAR(held[1], 1 / std::sqrt(i11), 1e-9 * s1);
  EXPECT_LT(held[1], s1);
}

// A loss rough at a small scale (steps a common-random-numbers simulation leaves: a press more or
// less) on a quadratic of SE s. Central differences at a small step measure the roughness (here
// a curvature that gives an SE far from s); the quadratic through points spread over the search
// recovers s.
TEST(QuadraticSe, SeesThroughARoughLossWhereTheStencilDoesNot) {
  const double mu = 1.0, s = 0.2;
  auto f = [&](double x) {
    return (x - mu) * (x - mu) / (s * s) + 0.8 * std::floor(std::sin(x * 157.0) * 2.0);
  };
  std::vector<std::vector<double>> x;
  std::vector<double> y;
  for (int k = -12; k <= 12; ++k) {
    const double v = mu + 0.05 * k + 0.0123;
    x.push_back({v});
    y.push_back(f(v));
  }
  const auto se = quadratic_se(x, y, {mu}, {0.1}, {true});
  ASSERT_TRUE(std::isfinite(se[0]));
  EXPECT_NEAR(se[0], s, 0.1 * s);
  // The premise: the stencil at h = 0.01 around μ is off by more than 2× (or not estimable).
  const double h = 0.01;
  const double curv = (f(mu + h) - 2 * f(mu) + f(mu - h)) / (h * h);
  const double stencil_se = curv > 0 ? std::sqrt(2.0 / curv) : NAN;
  EXPECT_FALSE(stencil_se > s / 2 && stencil_se < 2 * s) << stencil_se;
}

// What does not determine a positive-definite quadratic gives NaN, never a number: too few
// points for the coefficients plus one residual, points on a line in 2-D, a maximum.
TEST(QuadraticSe, UndeterminedOrNotAMinimumIsNaN) {
  auto nan_all = [](const std::vector<double>& v) {
    for (double e : v)
      if (!std::isnan(e)) return false;
    return true;
  };
  // 1-D: 3 coefficients, so 3 points (the stencil alone) are too few; 4 are enough.
  std::vector<std::vector<double>> x = {{0.9}, {1.0}, {1.1}};
  std::vector<double> y = {0.25, 0.0, 0.25};
  EXPECT_TRUE(nan_all(quadratic_se(x, y, {1.0}, {0.1}, {true})));
  x.push_back({1.3});
  y.push_back(2.25);
  EXPECT_NEAR(quadratic_se(x, y, {1.0}, {0.1}, {true})[0], 0.2, 1e-9);
  // A maximum.
  for (double& v : y) v = -v;
  EXPECT_TRUE(nan_all(quadratic_se(x, y, {1.0}, {0.1}, {true})));
  // 2-D, every point on the line x1 = 2 x0: the cross terms are undetermined.
  std::vector<std::vector<double>> line;
  std::vector<double> ly;
  for (int k = 0; k < 10; ++k) {
    line.push_back({0.1 * k, 0.2 * k});
    ly.push_back(0.1 * k * 0.1 * k);
  }
  EXPECT_TRUE(nan_all(quadratic_se(line, ly, {0.5, 1.0}, {0.1, 0.1}, {true, true})));
  // A non-finite loss among the points.
  x = {{0.9}, {1.0}, {1.1}, {1.3}};
  y = {0.25, 0.0, NAN, 2.25};
  EXPECT_TRUE(nan_all(quadratic_se(x, y, {1.0}, {0.1}, {true})));
}

// The report gives both SEs and says when they disagree (the committed exp2 fit of
// visual_spatial_sd: stencil 0.19 mm, the quadratic through its 7 points 1.1 mm).
TEST(QuadraticSe, TheReportSaysWhenTheTwoSesDisagree) {
  palplab::protocols::CalibrationResult r;
  r.keys = {"visual_spatial_sd", "weber_fraction"};
  r.start = {0.004, 0.03};
  r.fitted = {0.006, 0.03};
  r.lo = {0.001, 0.0};
  r.hi = {0.02, 1.0};
  r.se = {0.000194, 0.0050};
  r.se_quadratic = {0.00111, 0.0053};
  r.quadratic_points = 7;
  const std::string t = palplab::protocols::to_text(r);
  EXPECT_NE(t.find("SE 0.00111 over the 7 points with a loss within 9 of the fit's"),
            std::string::npos)
      << t;
  EXPECT_NE(t.find("the two SEs of visual_spatial_sd differ by more than 2x"), std::string::npos)
      << t;
  EXPECT_EQ(t.find("the two SEs of weber_fraction"), std::string::npos) << t;
  // Not determined: no second SE, no comparison.
  r.se_quadratic = {NAN, NAN};
  const std::string u = palplab::protocols::to_text(r);
  EXPECT_EQ(u.find(" over the 7 points"), std::string::npos) << u;
  EXPECT_EQ(u.find("differ by more than 2x"), std::string::npos) << u;
}

TEST(ParseBound, NameLowHigh) {
  const auto b = parse_bound("weber_fraction=0.04:1e-1");
  EXPECT_EQ(b.name, "weber_fraction");
  EXPECT_DOUBLE_EQ(b.lo, 0.04);
  EXPECT_DOUBLE_EQ(b.hi, 0.1);
  const auto n = parse_bound("x=-2:-1");
  EXPECT_DOUBLE_EQ(n.lo, -2);
  EXPECT_DOUBLE_EQ(n.hi, -1);
  // As a shell user may write them: blanks around a number, one leading '+'; -0 is 0.
  const auto w = parse_bound("x= 0.04 :+0.1");
  EXPECT_DOUBLE_EQ(w.lo, 0.04);
  EXPECT_DOUBLE_EQ(w.hi, 0.1);
  const auto z = parse_bound("x=-0:1");
  EXPECT_FALSE(std::signbit(z.lo));
}

TEST(ParseBound, BadTextSaysWhatIsWrong) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"weber_fraction", "no '='"},
      {"=0.1:0.2", "no parameter name before '='"},
      {"weber_fraction=0.04", "no ':' between LO and HI"},
      {"weber_fraction=:0.1", "LO \"\" is not a number"},
      {"weber_fraction=0.04:", "HI \"\" is not a number"},
      {"weber_fraction=0.04:0.1x", "HI \"0.1x\" is not a number"},
      {"weber_fraction=++0.04:0.1", "LO \"++0.04\" is not a number"},
      {"weber_fraction=0x1p-3:0.5", "LO \"0x1p-3\" is not a number"},
      {"weber_fraction=1e-400:0.5", "LO \"1e-400\" is too small (below the smallest double)"},
      {"weber_fraction=nan:0.1", "LO is not finite"},
      {"weber_fraction=0:inf", "HI is not finite"},
      {"weber_fraction=1e999:2e999", "LO \"1e999\" is too large in magnitude"},
      {"weber_fraction=0.1:0.04", "LO is not below HI"},
      {"weber_fraction=0.1:0.1", "LO is not below HI"},
      {"weber_fraction=0.1:0.2:0.3", "HI \"0.2:0.3\" is not a number"},
  };
  for (const auto& [text, why] : cases) {
    try {
      parse_bound(text);
      ADD_FAILURE() << text << " was accepted";
    } catch (const palplab::InputError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("--bounds"), std::string::npos) << m;
      EXPECT_NE(m.find("\"" + text + "\": " + why), std::string::npos) << text << "\n" << m;
      EXPECT_NE(m.find("expected NAME=LO:HI"), std::string::npos) << m;
    }
  }
}
