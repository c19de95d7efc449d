#pragma once
// Internal helpers of the mesh readers and writers: a line reader that knows where it is, strict
// number parsing and located errors; an output file written whole or not at all. Not part
// of the public API.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "common/escape.hpp"
#include "common/input_error.hpp"
#include "common/read_file.hpp"
#include "common/write_file.hpp"

namespace palplab::mesh::detail {

// A mesh file is composed in memory (open_out) and written whole or not at all (finish_out:
// common/write_file — a full disk says why and leaves no cut-off file, nor does an interruption).
inline std::ostringstream open_out(const std::string& /*path*/, bool /*binary*/ = false) {
  return std::ostringstream(std::ios::out | std::ios::binary);
}

inline void finish_out(std::ostringstream& out, const std::string& path) {
  write_file(path, out.view(), "the mesh file");
}

// A mesh file's bytes: the system's reason when it cannot be read, a directory said as such, a
// FIFO or device read only up to the limit (2 000 000 vertices as text are ≈ 300 MB).
inline std::string read_file(const std::string& path) {
  return read_file_bounded(path, std::size_t{2} << 30, "mesh file");
}

inline std::vector<std::string> split_ws(const std::string& s) {
  std::vector<std::string> out;
  std::istringstream is(s);
  std::string t;
  while (is >> t) out.push_back(t);
  return out;
}

// Reads a text buffer line by line; strips `comment` to end of line and surrounding space.
struct TextReader {
  std::string path;
  std::string data;
  size_t pos = 0;
  int line = 0;
  char comment = '#';

  TextReader(std::string p, char c = '#') : path(std::move(p)), data(read_file(path)), comment(c) {}
  TextReader(std::string p, std::string d, char c)
      : path(std::move(p)), data(std::move(d)), comment(c) {}

  // Next line (raw, without newline); false at the end.
  bool raw(std::string& out) {
    if (pos >= data.size()) return false;
    size_t e = data.find('\n', pos);
    if (e == std::string::npos) e = data.size();
    out.assign(data, pos, e - pos);
    if (!out.empty() && out.back() == '\r') out.pop_back();
    pos = e + 1;
    ++line;
    return true;
  }
  // Next non-empty line with comments stripped, split into tokens; false at the end.
  bool tokens(std::vector<std::string>& out) {
    std::string l;
    while (raw(l)) {
      if (comment) {
        if (auto h = l.find(comment); h != std::string::npos) l.erase(h);
      }
      out = split_ws(l);
      if (!out.empty()) return true;
    }
    return false;
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(SourceLocation{path, line}, what);
  }
  double number(const std::string& t, const char* what) const {
    double v;
    auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (r.ec != std::errc() || r.ptr != t.data() + t.size() || !std::isfinite(v))
      fail(std::string("expected ") + what + " (a finite number), got '" + shown_text(t, 40) + "'");
    return v;
  }
  // An integer that fits an int after subtracting `base` (indices, markers).
  int int32(const std::string& t, const char* what, long base = 0) const {
    const long v = integer(t, what);
    if (v < -2147483647L + base || v > 2147483647L + base)
      fail(std::string("expected ") + what + " (an integer that fits 32 bits), got '" +
           shown_text(t, 40) + "'");
    return static_cast<int>(v - base);
  }
  long integer(const std::string& t, const char* what) const {
    long v;
    auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (r.ec != std::errc() || r.ptr != t.data() + t.size())
      fail(std::string("expected ") + what + " (an integer), got '" + shown_text(t, 40) + "'");
    return v;
  }
};

// Guards against absurd counts in headers before allocating.
// Every record takes at least two bytes ("0\n"), so a count beyond half the bytes left is a lie
// that would otherwise allocate gigabytes before the first record is read.
inline void check_count(const TextReader& r, long n, const char* what, long max = 500000000) {
  const long left = static_cast<long>(r.data.size() - std::min(r.pos, r.data.size()));
  if (n < 0 || n > max || n > left / 2 + 1)
    r.fail(std::string("implausible ") + what + " count " + std::to_string(n) + " (the file has " +
           std::to_string(left) + " bytes left)");
}

// Region names go into JSON (mesh info, the results database, the report): each must be UTF-8
// without control characters (review 2026-12-06, second: a Latin-1 name was an internal error).
inline void check_region_names(const std::vector<std::string>& names, const std::string& path) {
  for (const std::string& n : names) {
    const bool control = std::any_of(n.begin(), n.end(), [](char c) {
      return static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
    });
    if (!is_valid_utf8(n) || control) {
      std::string shown;  // every byte outside printable ASCII as \xNN
      for (const char c : n.substr(0, 64)) {
        const auto u = static_cast<unsigned char>(c);
        char b[8];
        std::snprintf(b, sizeof b, "\\x%02x", u);
        shown += (u < 0x20 || u >= 0x7f) ? std::string(b) : std::string(1, c);
      }
      throw InputError("region name \"" + shown + "\" is " +
                           (control ? "not printable text (control characters)"
                                    : "not UTF-8 text (another encoding?)") +
                           ": expected UTF-8 names",
                       path);
    }
  }
}

}  // namespace palplab::mesh::detail
