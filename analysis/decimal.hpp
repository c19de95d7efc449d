#pragma once
// Exact decimal centring. Data such as NIST SmLs09 (1000000000000.4, ...) lose their spread
// when each value is rounded to double before subtracting: 1e12 in double has a resolution of
// 1.2e-4, so a spread of 0.1 keeps only ~3 digits. Parsing the decimal text exactly and
// subtracting a centre *before* rounding keeps every digit of the deviations; all the
// statistics that are shift-invariant (SD, t, F, ranks, ...) are then computed from them.
#include <optional>
#include <string_view>
#include <vector>

namespace palplab::analysis {

// A decimal number m · 10^e with |m| < 10^36 (36 significant digits).
struct Decimal {
  __int128 mantissa = 0;
  int exponent = 0;
};

// Parses "[+-]digits[.digits][(e|E)[+-]digits]" (surrounding blanks allowed); nullopt when the
// text is not of that form or has more than 36 significant digits.
std::optional<Decimal> parse_decimal(std::string_view text);

// x - c rounded once to the nearest double (exact decimal subtraction, then one rounding).
// Falls back to long double arithmetic when the aligned mantissas would not fit.
double decimal_difference(std::string_view x, std::string_view c);

// Sign of the exact decimal difference a - b (-1, 0, 1).
int compare_decimals(std::string_view a, std::string_view b);

// Values as offsets from a centre: value_i = centre + dev_i. The centre depends only on the
// set of values, not on their order: the lower median (exact decimal order) when every value
// lies within a quarter of its magnitude from it (then dev_i = decimal_difference(text_i,
// median), one rounding, no digit lost: NIST SmLs09's 1000000000000.4 keeps its .4);
// otherwise 0 and dev_i is the value as written, rounded once (strtod).
struct CentredValues {
  double centre = 0;
  std::vector<double> dev;
};
// `texts` must already be valid numbers (see parse_number in csv.hpp).
CentredValues centre_decimals(const std::vector<std::string_view>& texts);

}  // namespace palplab::analysis
