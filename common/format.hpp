#pragma once
// A number in a message, to a few significant digits (printf's %g: "0.0123", "2.5e+07", "nan",
// "inf"). Messages that quote a value back to the user exactly use mesh::format_exact instead.
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace palplab {

inline std::string format_g(double x, int digits = 3) {
  char b[40];
  std::snprintf(b, sizeof b, "%.*g", digits, x);
  return b;
}

// The shortest text that reads back as exactly x ("0.1", "15.633", "1e+300", "inf", "nan";
// std::to_chars): for messages that quote a value, where "0.30000000000000004" must not be
// shown as "0.3" nor "15.633" as "15.633000000000001".
inline std::string format_shortest(double x) {
  char b[64];
  const auto r = std::to_chars(b, b + sizeof b, x);
  return std::string(b, r.ptr);
}

// Significant digits of format_shortest's text (1 for 0, inf and nan).
inline int shortest_digits(double x) {
  if (!std::isfinite(x) || x == 0) return 1;
  char b[64];
  const auto r = std::to_chars(b, b + sizeof b, x, std::chars_format::scientific);
  int n = 0;
  for (const char* c = b; c < r.ptr && *c != 'e'; ++c) n += *c >= '0' && *c <= '9';
  return n;
}

// x in fixed notation with the fewest decimals (at most 17) that give x back within a relative
// tolerance: for a value computed with round-off ("0.0105", not "0.010499999999999999").
inline std::string format_fixed_within(double x, double relative_tolerance = 1e-12) {
  char b[400];
  for (int decimals = 0; decimals <= 17; ++decimals) {
    std::snprintf(b, sizeof b, "%.*f", decimals, x);
    if (std::abs(std::strtod(b, nullptr) - x) <= relative_tolerance * std::abs(x)) break;
  }
  return b;
}

}  // namespace palplab
