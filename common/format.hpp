#pragma once
// A number in a message, to a few significant digits (printf's %g: "0.0123", "2.5e+07", "nan",
// "inf"). Messages that quote a value back to the user exactly use mesh::format_exact instead.
#include <cstdio>
#include <string>

namespace palplab {

inline std::string format_g(double x, int digits = 3) {
  char b[40];
  std::snprintf(b, sizeof b, "%.*g", digits, x);
  return b;
}

}  // namespace palplab
