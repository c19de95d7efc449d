#pragma once
// Shapiro–Wilk W test of normality with Royston's (1995, Algorithm AS R94) approximations
// for the coefficients and the p-value, the algorithm of R's shapiro.test.
#include <vector>

namespace palplab::analysis {

struct ShapiroWilk {
  double W = 0, p = 1;
  bool defined = true;  // false when all values are equal
};
// x  #x values, 3 <= #x <= 5000 (std::invalid_argument otherwise).
ShapiroWilk shapiro_wilk(std::vector<double> x);

}  // namespace palplab::analysis
