// The grades of `palplab recheck` (analysis/recheck.hpp): a printed value is consistent when the
// recomputed one rounds to it, a rounding difference when it is off by at most one unit of the
// last printed digit and at most 5 % of the value, and a printed p that reverses the verdict at
// .05 is never a rounding.
#include <gtest/gtest.h>

#include "analysis/recheck.hpp"

using palplab::analysis::classify_number;
using palplab::analysis::classify_p;

TEST(RecheckGrades, ANumberRoundedIsConsistentCutIsRounding) {
  EXPECT_EQ(classify_number(11.05, 2, 11.045142662145704), "consistent");
  EXPECT_EQ(classify_number(11.04, 2, 11.045142662145704), "rounding");  // cut, not rounded
  EXPECT_EQ(classify_number(11.05, 2, 11.0449), "rounding");     // from data rounded in the CSV
  EXPECT_EQ(classify_number(11.07, 2, 11.045), "inconsistent");  // more than one unit off
  EXPECT_EQ(classify_number(-3.02, 2, -3.0249), "consistent");
  EXPECT_EQ(classify_number(-3.20, 2, -3.0249), "inconsistent");  // transposed digits
  EXPECT_TRUE(std::string(classify_number(1.0, 2, NAN)) == "not recomputable");
}

// Review 2026-12-07: with few printed decimals one unit is most of the value.
TEST(RecheckGrades, OneUnitOfAFewDecimalsIsNoLicence) {
  EXPECT_EQ(classify_number(12, 0, 11.045), "inconsistent");  // 8.6 % off
  EXPECT_EQ(classify_number(11, 0, 11.045), "consistent");
  EXPECT_EQ(classify_number(0.1, 1, 0.0016), "inconsistent");  // one unit, but 98 % off
  EXPECT_EQ(classify_number(1, 0, 0.0016), "inconsistent");
  EXPECT_EQ(classify_number(100, 0, 99.4), "rounding");  // 0.6 %
  // Cut digits are a rounding difference however small the value (review of the fix,
  // 2026-12-07): MINITAB's truncated Welch df, a p of data the CSV holds rounded.
  EXPECT_EQ(classify_number(3, 0, 3.58824), "rounding");
  EXPECT_EQ(classify_number(.02, 2, .0250589), "rounding");
  EXPECT_EQ(classify_number(.001, 3, .00157), "rounding");
  EXPECT_EQ(classify_number(-3.02, 2, -3.0249), "consistent");
  EXPECT_EQ(classify_number(-3.01, 2, -3.0149), "consistent");
  EXPECT_EQ(classify_number(-3.01, 2, -3.0199), "rounding");  // cut towards zero
}

TEST(RecheckGrades, APrintedPThatReversesTheVerdictIsNeverRounding) {
  EXPECT_EQ(classify_p("=", .002, 3, .0016), "consistent");
  EXPECT_EQ(classify_p("=", .1, 1, .0016), "inconsistent");
  EXPECT_EQ(classify_p("=", .02, 2, .0250589), "rounding");  // cut, same side
  EXPECT_EQ(classify_p("=", .05, 2, .0563), "rounding");     // cut, not below .05 either
  // Within one unit and 5 % (a rounding as a number), but on the other side of .05: the
  // opposite verdict.
  EXPECT_EQ(classify_number(.0499, 4, .05), "rounding");
  EXPECT_EQ(classify_p("=", .0499, 4, .05), "inconsistent");
  EXPECT_EQ(classify_p("=", .049, 3, .0509), "inconsistent");  // more than one unit
  EXPECT_EQ(classify_p("=", .051, 3, .0509), "consistent");
  // A cut p on the same side stays a rounding difference.
  EXPECT_EQ(classify_p("=", .312, 3, .3129), "rounding");
  EXPECT_EQ(classify_p("=", .049, 3, .056), "inconsistent");  // 12.5 % off and reversed
  // Bounds hold or not: no slack.
  EXPECT_EQ(classify_p("<", .05, 2, .051), "inconsistent");
  EXPECT_EQ(classify_p("<", .001, 3, .0009), "consistent");
  EXPECT_EQ(classify_p(">", .05, 2, .2), "consistent");
}
