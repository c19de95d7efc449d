#pragma once
// The quiet NaN that marks an undefined statistic (a variance of one value, a p-value of no
// test), one name for the whole code base.
#include <limits>

namespace palplab {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace palplab
