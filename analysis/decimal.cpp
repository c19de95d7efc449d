#include "analysis/decimal.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numeric>
#include <string>

namespace palplab::analysis {

namespace {

constexpr int kMaxDigits = 36;

__int128 pow10_i128(int p) {
  __int128 r = 1;
  for (int i = 0; i < p; ++i) r *= 10;
  return r;
}

std::string to_string_i128(__int128 v) {
  bool neg = v < 0;
  unsigned __int128 u =
      neg ? static_cast<unsigned __int128>(-(v + 1)) + 1u : static_cast<unsigned __int128>(v);
  std::string s;
  do {
    s.insert(s.begin(), static_cast<char>('0' + static_cast<int>(u % 10)));
    u /= 10;
  } while (u);
  if (neg) s.insert(s.begin(), '-');
  return s;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

}  // namespace

std::optional<Decimal> parse_decimal(std::string_view text) {
  std::string_view s = trim(text);
  size_t i = 0;
  bool neg = false;
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) neg = s[i++] == '-';
  __int128 m = 0;
  int digits = 0;  // significant digits accumulated into m
  int exp = 0;
  bool any = false;
  bool frac = false;
  for (; i < s.size(); ++i) {
    char c = s[i];
    if (c == '.') {
      if (frac) return std::nullopt;
      frac = true;
      continue;
    }
    if (c < '0' || c > '9') break;
    any = true;
    if (m == 0 && c == '0') {  // leading zeros carry no digits
      if (frac) --exp;
      continue;
    }
    if (digits >= kMaxDigits) return std::nullopt;
    m = m * 10 + (c - '0');
    ++digits;
    if (frac) --exp;
  }
  if (!any) return std::nullopt;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    bool eneg = false;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) eneg = s[i++] == '-';
    if (i >= s.size()) return std::nullopt;
    long e = 0;
    for (; i < s.size(); ++i) {
      if (s[i] < '0' || s[i] > '9') return std::nullopt;
      e = e * 10 + (s[i] - '0');
      if (e > 100000) return std::nullopt;
    }
    exp += static_cast<int>(eneg ? -e : e);
  }
  if (i != s.size()) return std::nullopt;
  return Decimal{neg ? -m : m, exp};
}

double decimal_difference(std::string_view x, std::string_view c) {
  auto a = parse_decimal(x);
  auto b = parse_decimal(c);
  if (a && b) {
    int e = std::min(a->exponent, b->exponent);
    int sa = a->exponent - e, sb = b->exponent - e;
    auto fits = [](__int128 m, int shift) {
      if (m == 0) return true;
      if (shift > kMaxDigits) return false;
      __int128 lim = pow10_i128(kMaxDigits + 1 - shift);  // |m|·10^shift < 10^37 keeps room
      return (m < 0 ? -m : m) < lim;
    };
    if (fits(a->mantissa, sa) && fits(b->mantissa, sb)) {
      __int128 d = a->mantissa * pow10_i128(sa) - b->mantissa * pow10_i128(sb);
      if (d == 0) return 0.0;
      // strtod rounds the exact decimal correctly: the only rounding of the deviation.
      std::string t = to_string_i128(d) + "e" + std::to_string(e);
      return std::strtod(t.c_str(), nullptr);
    }
  }
  std::string xs(trim(x)), cs(trim(c));
  long double d = std::strtold(xs.c_str(), nullptr) - std::strtold(cs.c_str(), nullptr);
  return static_cast<double>(d);
}

int compare_decimals(std::string_view a, std::string_view b) {
  if (trim(a) == trim(b)) return 0;
  double d = decimal_difference(a, b);
  if (d != 0) return d < 0 ? -1 : 1;
  // Zero after rounding: equal values written differently ("1.0", "1") or a difference below
  // the double range; long double settles the second.
  std::string as(trim(a)), bs(trim(b));
  long double x = std::strtold(as.c_str(), nullptr), y = std::strtold(bs.c_str(), nullptr);
  return x < y ? -1 : (x > y ? 1 : 0);
}

CentredValues centre_decimals(const std::vector<std::string_view>& texts) {
  CentredValues r;
  if (texts.empty()) return r;
  const size_t n = texts.size();
  std::vector<double> x(n);
  for (size_t i = 0; i < n; ++i) {
    std::string t(trim(texts[i]));
    x[i] = std::strtod(t.c_str(), nullptr);
  }
  // The centre is the lower median in the exact decimal order, so it depends on the values,
  // never on which row comes first (nth_element with a total order: equal doubles are ordered
  // by their exact decimal values).
  std::vector<size_t> idx(n);
  std::iota(idx.begin(), idx.end(), size_t{0});
  auto less = [&](size_t a, size_t b) {
    if (x[a] != x[b]) return x[a] < x[b];
    return compare_decimals(texts[a], texts[b]) < 0;
  };
  const size_t mid = (n - 1) / 2;
  std::nth_element(idx.begin(), idx.begin() + static_cast<std::ptrdiff_t>(mid), idx.end(), less);
  const size_t c = idx[mid];
  double spread = 0;
  for (double v : x) spread = std::max(spread, std::fabs(v - x[c]));
  r.dev.reserve(n);
  // Centring helps only when every value shares the centre's leading digits. With
  // |x - c| <= |c|/4 for all x, |x| >= 3|c|/4, so the one rounding of x - c (<= ulp(|c|/4)/2)
  // is below the rounding of x itself: no value loses a digit. Otherwise (values of different
  // magnitudes, e.g. 1e15 beside 1.1) the values are taken as written, rounded once each.
  if (x[c] != 0 && spread <= 0.25 * std::fabs(x[c])) {
    r.centre = x[c];
    for (auto t : texts) r.dev.push_back(decimal_difference(t, texts[c]));
  } else {
    r.centre = 0;
    r.dev = x;
  }
  return r;
}

}  // namespace palplab::analysis
