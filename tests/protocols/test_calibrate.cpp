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

TEST(NelderMead, FindsTheMinimumOfAQuadraticInsideTheBox) {
  auto f = [](const std::vector<double>& x) {
    return std::pow(x[0] - 0.3, 2) + 4 * std::pow(x[1] + 0.2, 2);
  };
  const auto r = nelder_mead(f, {1.0, 1.0}, {0.25, 0.25}, {-2, -2}, {2, 2}, 200);
  EXPECT_NEAR(r.x[0], 0.3, 2e-3);
  EXPECT_NEAR(r.x[1], -0.2, 2e-3);
  EXPECT_LE(r.evaluations, 200);
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
