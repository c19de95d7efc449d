#pragma once
// Errors in user-facing input (study/prototype JSON, meshes, CSV, CLI flags, device data).
// Every library throws palplab::InputError for bad input; the command line turns it into a
// message on stderr and exit code 2. A problem says where (file, line/column or byte offset,
// JSON path) and what was expected, so a researcher can act on it.
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "common/escape.hpp"

namespace palplab {

struct SourceLocation {
  std::string file;       // empty when the input is not a file (a flag, a string)
  int line = 0;           // 1-based; 0 = unknown
  int column = 0;         // 1-based; 0 = unknown
  long byte_offset = -1;  // for binary files; -1 = unknown
  std::string json_path;  // "$.groups[1].size"; empty when not JSON
};

struct Problem {
  SourceLocation where;
  std::string what;

  // "FILE:LINE:COL: $.path: what" — the parts that are unknown are left out. Control
  // characters from the input (escape sequences in a name) are shown escaped, never raw.
  std::string format() const { return escape_controls(format_raw(), false); }
  std::string format_raw() const {
    std::string s;
    if (!where.file.empty()) s += where.file + ":";
    if (where.line > 0) {
      s += std::to_string(where.line) + ":";
      if (where.column > 0) s += std::to_string(where.column) + ":";
    } else if (where.byte_offset >= 0) {
      s += "byte " + std::to_string(where.byte_offset) + ":";
    }
    if (!where.json_path.empty()) s += (s.empty() ? "" : " ") + where.json_path + ":";
    return s.empty() ? what : s + " " + what;
  }
};

class InputError : public std::runtime_error {
 public:
  explicit InputError(std::vector<Problem> problems)
      : std::runtime_error(join(problems)), problems_(std::move(problems)) {}
  InputError(SourceLocation where, std::string what)
      : InputError(std::vector<Problem>{Problem{std::move(where), std::move(what)}}) {}
  // A problem with no location beyond a file name (or none at all).
  explicit InputError(std::string what, std::string file = {})
      : InputError(SourceLocation{std::move(file)}, std::move(what)) {}

  const std::vector<Problem>& problems() const { return problems_; }

 private:
  // The first kShownProblems problems, then their count: a device-sim script of a million bad
  // waypoints printed 117 MB (review 2026-12-07). problems() keeps them all.
  static constexpr size_t kShownProblems = 100;
  static std::string join(const std::vector<Problem>& ps) {
    std::string s;
    for (size_t i = 0; i < ps.size() && i < kShownProblems; ++i) {
      if (i) s += '\n';
      s += ps[i].format();
    }
    if (ps.size() > kShownProblems)
      s += "\n... and " + std::to_string(ps.size() - kShownProblems) +
           " more problems (the first " + std::to_string(kShownProblems) + " are shown)";
    return s;
  }
  std::vector<Problem> problems_;
};

}  // namespace palplab
