#include "common/json_check.hpp"

#include "common/escape.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <tuple>

namespace palplab::json {

using nlohmann::json;

const char* kind_name(const json& j) {
  switch (j.type()) {
    case json::value_t::null:
      return "null";
    case json::value_t::boolean:
      return "a boolean";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
      return "an integer";
    case json::value_t::number_float:
      return "a number";
    case json::value_t::string:
      return "a string";
    case json::value_t::array:
      return "an array";
    case json::value_t::object:
      return "an object";
    default:
      return "an unsupported value";
  }
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> d(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) d[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t prev = d[0];
    d[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      std::size_t cur = d[j];
      d[j] = std::min({d[j] + 1, d[j - 1] + 1, prev + (a[i - 1] == b[j - 1] ? 0 : 1)});
      prev = cur;
    }
  }
  return d[b.size()];
}

json parse_json_file(const std::string& path, std::string* text_out,
                     std::vector<Problem>* duplicates) {
  return parse_file_located(path, text_out, duplicates);
}

namespace {

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
  return s;
}

// The value as it appears in a message; long strings are cut.
std::string shown(const json& v) {
  std::string s = v.dump(-1, ' ', false, json::error_handler_t::replace);
  return s.size() > 60 ? s.substr(0, 60) + "..." : s;
}

// Why a value is not an integer, for "expected ..., got <this>": a whole number written beyond
// the 64-bit range (the parser keeps it as a double) is out of range, not "a number".
// `literal` is the number as written in the file (the double's digits would differ).
std::string not_an_integer(const json& v, const std::string& literal, const char* range) {
  if (v.is_number_float()) {
    const double x = v.get<double>();
    const std::string as_written = literal.empty() ? shown(v) : literal;
    if (std::isfinite(x) && x == std::floor(x))
      return std::fabs(x) >= 9.2e18 ? as_written + ", out of range " + range
                                    : as_written + " (write an integer as digits only)";
    return "a number with a fraction, " + as_written;
  }
  return kind_name(v);
}

// The number token starting at `offset` of `text` ("" when there is none).
std::string number_literal(std::string_view text, long offset) {
  if (offset < 0 || static_cast<std::size_t>(offset) >= text.size()) return "";
  std::size_t e = static_cast<std::size_t>(offset);
  while (e < text.size() && e - offset < 60 && std::strchr("+-0123456789.eE", text[e]) && text[e])
    ++e;
  return std::string(text.substr(offset, e - offset));
}

}  // namespace

Checker::Checker(std::string file, std::string_view text) : file_(std::move(file)), text_(text) {}

void Checker::err(const std::string& path, const std::string& what, bool at_key) {
  problems_.push_back({locator().locate(file_, path, at_key), what});
}

void Checker::throw_if_any() {
  if (problems_.empty()) return;
  auto key = [&](const Problem& p) {
    return std::tuple(p.where.file == file_ ? 0 : 1, p.where.file, p.where.line, p.where.column);
  };
  std::stable_sort(problems_.begin(), problems_.end(),
                   [&](const Problem& a, const Problem& b) { return key(a) < key(b); });
  throw InputError(problems_);
}

std::string did_you_mean(std::string_view got, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t bd = 3;
  for (const auto& a : candidates)
    if (auto d = edit_distance(got, a); d < bd) bd = d, best = a;
  return best.empty() ? std::string() : " (did you mean \"" + best + "\"?)";
}

void Checker::keys(const json& o, const std::string& path,
                   const std::vector<std::string>& allowed) {
  if (!o.is_object()) return;
  for (auto it = o.begin(); it != o.end(); ++it) {
    if (std::find(allowed.begin(), allowed.end(), it.key()) != allowed.end()) continue;
    std::string msg = "unknown key \"" + it.key() + "\"" + did_you_mean(it.key(), allowed);
    msg += "; expected one of: " + join(allowed);
    err(path_key(path, it.key()), msg, true);
  }
}

void Checker::keys(const json& o, const std::string& path,
                   std::initializer_list<const char*> allowed) {
  keys(o, path, std::vector<std::string>(allowed.begin(), allowed.end()));
}

bool Checker::expect_object(const json& j, const std::string& path) {
  if (j.is_object()) return true;
  err(path, std::string("expected an object, got ") + kind_name(j));
  return false;
}

const json* Checker::member(const json& o, const std::string& path, const char* key, bool required,
                            const char* expected) {
  if (!o.is_object()) return nullptr;
  auto it = o.find(key);
  if (it == o.end()) {
    if (required) err(path, std::string("missing required key \"") + key + "\" (" + expected + ")");
    return nullptr;
  }
  return &*it;
}

const json* Checker::object(const json& o, const std::string& path, const char* key,
                            bool required) {
  const json* v = member(o, path, key, required, "an object");
  if (v && !expect_object(*v, path_key(path, key))) return nullptr;
  return v;
}

std::string Checker::fmt(double x) {
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  if (std::isnan(x)) return "nan";  // JSON would say null
  return json(x).dump();
}

bool Checker::in_range(const json& v, const std::string& p, double lo, double hi, const char* what,
                       bool lo_open) {
  const double x = v.get<double>();
  if (std::isfinite(x) && x >= lo && x <= hi && !(lo_open && x == lo)) return true;
  err(p, "value " + shown(v) + " out of range: expected " + what + " in " + (lo_open ? "(" : "[") +
             fmt(lo) + ", " + fmt(hi) + "]");
  return false;
}

std::optional<double> Checker::number(const json& o, const std::string& path, const char* key,
                                      bool required, double lo, double hi, const char* what,
                                      bool lo_open) {
  const json* v = member(o, path, key, required, what);
  if (!v) return std::nullopt;
  const std::string p = path_key(path, key);
  if (!v->is_number()) {
    err(p, std::string("expected a number: ") + what + ", got " + kind_name(*v));
    return std::nullopt;
  }
  if (!in_range(*v, p, lo, hi, what, lo_open)) return std::nullopt;
  return v->get<double>();
}

std::optional<double> Checker::num(const json& o, const std::string& path, const char* key,
                                   bool required, const char* expected) {
  const json* v = member(o, path, key, required, expected);
  if (!v) return std::nullopt;
  if (!v->is_number() || !std::isfinite(v->get<double>())) {
    err(path_key(path, key), std::string("expected ") + expected + ", got " + kind_name(*v));
    return std::nullopt;
  }
  return v->get<double>();
}

std::optional<long long> Checker::integer(const json& o, const std::string& path, const char* key,
                                          bool required, long long lo, long long hi,
                                          const char* what) {
  const json* v = member(o, path, key, required, what);
  if (!v) return std::nullopt;
  const std::string p = path_key(path, key);
  const std::string range = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  if (!v->is_number_integer()) {
    err(p, std::string("expected an integer: ") + what + " in " + range + ", got " +
               (v->is_number() ? shown(*v) : kind_name(*v)));
    return std::nullopt;
  }
  // number_unsigned may exceed long long; compare before converting (no wrap-around).
  const bool too_big =
      v->is_number_unsigned() &&
      v->get<unsigned long long>() > static_cast<unsigned long long>(hi < 0 ? 0 : hi);
  if (too_big || v->get<long long>() < lo || v->get<long long>() > hi) {
    err(p, "value " + shown(*v) + " out of range: expected " + what + " in " + range);
    return std::nullopt;
  }
  return v->get<long long>();
}

std::optional<long long> Checker::integer(const json& o, const std::string& path, const char* key,
                                          bool required, const char* expected) {
  const json* v = member(o, path, key, required, expected);
  if (!v) return std::nullopt;
  const std::string p = path_key(path, key);
  if (!v->is_number_integer()) {
    err(p, std::string("expected ") + expected + ", got " +
               not_an_integer(*v, number_literal(text_, locator().value(p).offset),
                              "[-9223372036854775808, 9223372036854775807]"));
    return std::nullopt;
  }
  if (v->is_number_unsigned() &&
      v->get<unsigned long long>() >
          static_cast<unsigned long long>(std::numeric_limits<long long>::max())) {
    err(p, "value " + shown(*v) + " out of range: expected " + expected);
    return std::nullopt;
  }
  return v->get<long long>();
}

std::optional<unsigned long long> Checker::uint64(const json& o, const std::string& path,
                                                  const char* key, bool required,
                                                  const char* expected) {
  const json* v = member(o, path, key, required, expected);
  if (!v) return std::nullopt;
  if (v->is_number_unsigned() || (v->is_number_integer() && v->get<long long>() >= 0))
    return v->get<unsigned long long>();
  err(path_key(path, key),
      std::string("expected ") + expected + ", got " +
          (v->is_number_integer()
               ? "a negative integer"
               : not_an_integer(*v,
                                number_literal(text_, locator().value(path_key(path, key)).offset),
                                "[0, 18446744073709551615]")));
  return std::nullopt;
}

std::optional<bool> Checker::boolean(const json& o, const std::string& path, const char* key,
                                     bool required) {
  const json* v = member(o, path, key, required, "true or false");
  if (!v) return std::nullopt;
  if (!v->is_boolean()) {
    err(path_key(path, key), std::string("expected true or false, got ") + kind_name(*v));
    return std::nullopt;
  }
  return v->get<bool>();
}

std::optional<std::string> Checker::text(const json& o, const std::string& path, const char* key,
                                         bool required,
                                         std::initializer_list<const char*> allowed) {
  const json* v = member(o, path, key, required, "a string");
  if (!v) return std::nullopt;
  const std::string p = path_key(path, key);
  if (!v->is_string()) {
    err(p, std::string("expected a string, got ") + kind_name(*v));
    return std::nullopt;
  }
  std::string s = v->get<std::string>();
  if (allowed.size()) {
    std::vector<std::string> opts(allowed.begin(), allowed.end());
    if (std::find(opts.begin(), opts.end(), s) == opts.end()) {
      err(p, shown(*v) + " is not one of: " + join(opts));
      return std::nullopt;
    }
  }
  return s;
}

std::optional<std::string> Checker::nonempty_text(const json& o, const std::string& path,
                                                  const char* key, bool required) {
  const json* v = member(o, path, key, required, "a string");
  if (!v) return std::nullopt;
  if (!v->is_string() || v->get<std::string>().empty()) {
    err(path_key(path, key), std::string("expected a non-empty string, got ") +
                                 (v->is_string() ? "an empty string" : kind_name(*v)));
    return std::nullopt;
  }
  return v->get<std::string>();
}

std::optional<std::string> Checker::one_of(const json& o, const std::string& path, const char* key,
                                           bool required, const std::vector<std::string>& options) {
  auto s = nonempty_text(o, path, key, required);
  if (!s) return s;
  if (std::find(options.begin(), options.end(), *s) == options.end()) {
    err(path_key(path, key), shown(json(*s)) + " is not one of: " + join(options));
    return std::nullopt;
  }
  return s;
}

std::optional<std::array<double, 3>> Checker::vec3(const json& o, const std::string& path,
                                                   const char* key, bool required, double lo,
                                                   double hi, const char* what) {
  const json* v = member(o, path, key, required, what);
  if (!v) return std::nullopt;
  const std::string p = path_key(path, key);
  if (!v->is_array() || v->size() != 3) {
    err(p, std::string("expected [x, y, z]: ") + what + ", got " +
               (v->is_array() ? "an array of " + std::to_string(v->size()) : kind_name(*v)));
    return std::nullopt;
  }
  std::array<double, 3> out{};
  bool ok = true;
  for (std::size_t i = 0; i < 3; ++i) {
    const json& e = (*v)[i];
    const std::string pi = path_index(p, i);
    if (!e.is_number()) {
      err(pi, std::string("expected a number: ") + what + ", got " + kind_name(e));
      ok = false;
    } else if (!in_range(e, pi, lo, hi, what, false)) {
      ok = false;
    } else {
      out[i] = e.get<double>();
    }
  }
  if (!ok) return std::nullopt;
  return out;
}

// The ids' grammar (declared in json_check.hpp): the problem is recorded; the caller keeps the
// id so that references to it do not report a second time.
namespace {
constexpr std::size_t kMaxIdLength = 64;
constexpr const char* kIdRule =
    "expected an id of 1 to 64 ASCII letters, digits, '_', '-' or '.', starting with a letter or "
    "digit (ids become file names and CSV cells)";

bool id_char(unsigned char b) {
  return (b >= 'a' && b <= 'z') || (b >= 'A' && b <= 'Z') || (b >= '0' && b <= '9') || b == '_' ||
         b == '-' || b == '.';
}
}  // namespace

void check_id(Checker& c, const std::string& id, const std::string& path) {
  // The id as shown in the message: a JSON string (quotes, backslashes and control characters
  // escaped, so that an id holding '"' or a newline cannot garble the message), cut after
  // kShownChars characters, with its length: "xxxx"… (65 characters).
  auto shown = [&] {
    constexpr std::size_t kShownChars = 40;
    const std::size_t cut = utf8_prefix(id, kShownChars), total = utf8_length(id);
    const auto quoted = [](const std::string& t) {
      return json(t).dump(-1, ' ', false, json::error_handler_t::replace);
    };
    if (cut == id.size()) return quoted(id);
    return quoted(id.substr(0, cut)) + "… (" + std::to_string(total) + " characters)";
  };
  std::size_t chars = 0;  // characters (UTF-8 code points) before i
  for (std::size_t i = 0; i < id.size(); ++chars) {
    const auto b = static_cast<unsigned char>(id[i]);
    // One UTF-8 character (the JSON parser has checked the encoding).
    std::size_t len = b < 0x80 ? 1 : b >> 5 == 0x6 ? 2 : b >> 4 == 0xE ? 3 : 4;
    len = std::min(len, id.size() - i);
    const bool first = i == 0;
    if (len == 1 && id_char(b) && !(first && (b == '_' || b == '-' || b == '.'))) {
      ++i;
      continue;
    }
    unsigned cp = len == 1 ? b : b & (0x7F >> len);
    for (std::size_t k = 1; k < len; ++k)
      cp = cp << 6 | (static_cast<unsigned char>(id[i + k]) & 0x3F);
    char u[16];
    std::snprintf(u, sizeof u, "U+%04X", cp);
    const bool printable = cp >= 0x20 && cp != 0x7f && !(cp >= 0x80 && cp <= 0x9f);
    const std::string what = printable ? "'" + id.substr(i, len) + "' (" + u + ")" : std::string(u);
    c.err(path, std::string(kIdRule) + ", got " + shown() + ": " +
                    (first && len == 1 && id_char(b)
                         ? "it starts with " + what
                         : what + " at character " + std::to_string(chars + 1)));
    return;
  }
  if (chars == 0)
    c.err(path, std::string(kIdRule) + ", got an empty id");
  else if (chars > kMaxIdLength)  // shown() gives the length
    c.err(path, std::string(kIdRule) + ", got " + shown());
}

}  // namespace palplab::json
