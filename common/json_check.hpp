#pragma once
// The one JSON reader and validator for user files (studies, prototypes, declared analyses).
//
// Every check collects a located problem instead of throwing, so a file reports all its mistakes
// at once, each worded the same way in every file kind:
//   FILE:LINE:COL: $.json.path: what was expected, got what
// Unknown members are errors (a typo must never fall back to a default silently). Numbers are
// read with their admissible range (NaN/inf/1e400 and values outside the target type, e.g. a
// group size of 4294967296, are errors, never wrapped or clamped).
//
// Use: parse with parse_json_file() (or json::parse_located for text), build one Checker over the
// same text, call the typed readers, then throw_if_any(). The readers return std::nullopt (and
// record a problem) when a value is missing-but-required, of the wrong type or out of range.
#include <array>
#include <initializer_list>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/input_error.hpp"
#include "common/json_locate.hpp"

namespace palplab::json {

// "a string", "an integer", "a number", "an object", ... (for "got ..." in messages).
const char* kind_name(const nlohmann::json& j);

// Edit distance, for "did you mean" hints.
std::size_t edit_distance(std::string_view a, std::string_view b);
// " (did you mean \"x\"?)" for the nearest of `candidates` within an edit distance of 2 of
// `got`, else "": the hint every "unknown ..." message appends.
std::string did_you_mean(std::string_view got, const std::vector<std::string>& candidates);

// Reads a JSON file: missing/unreadable file, syntax errors, nesting deeper than kMaxDepth,
// numbers that overflow a double (1e400) and duplicate keys are located InputErrors (with
// `duplicates`, repeated keys go there instead: add them to the file's Checker, so they are
// reported with its other problems).
nlohmann::json parse_json_file(const std::string& path, std::string* text_out = nullptr,
                               std::vector<Problem>* duplicates = nullptr);

class Checker {
 public:
  // `text` is the source the JSON was parsed from (for line:column); `file` names it.
  Checker(std::string file, std::string_view text);

  const std::string& file() const { return file_; }
  // Located on first use (an error): locating every value of a valid file costs more than
  // checking it.
  const JsonLocator& locator() const {
    if (!loc_) loc_.emplace(text_);
    return *loc_;
  }

  // Records a problem at `path` (at the member key when at_key, for unknown/misplaced keys).
  void err(const std::string& path, const std::string& what, bool at_key = false);
  // Problems found elsewhere (another file) join this report.
  void add(const Problem& p) { problems_.push_back(p); }
  void add(const std::vector<Problem>& ps) {
    problems_.insert(problems_.end(), ps.begin(), ps.end());
  }
  std::vector<Problem>& problems() { return problems_; }
  bool ok() const { return problems_.empty(); }
  // Throws every problem at once as one InputError, sorted in file order (this file first).
  void throw_if_any();

  // Every member of `o` must be one of `allowed`; others are errors at their key, with a
  // "did you mean" for a near miss.
  void keys(const nlohmann::json& o, const std::string& path,
            const std::vector<std::string>& allowed);
  void keys(const nlohmann::json& o, const std::string& path,
            std::initializer_list<const char*> allowed);

  // `j` (at `path`) must be an object; false (and a problem) otherwise.
  bool expect_object(const nlohmann::json& j, const std::string& path);

  // The member `key` of `o`, or nullptr (a problem when `required`; `expected` describes it).
  const nlohmann::json* member(const nlohmann::json& o, const std::string& path, const char* key,
                               bool required, const char* expected);
  // A member that must be an object.
  const nlohmann::json* object(const nlohmann::json& o, const std::string& path, const char* key,
                               bool required);

  // A finite number in [lo, hi] ((lo, hi] when lo_open). `what` names it: "the haptic step (s)".
  std::optional<double> number(const nlohmann::json& o, const std::string& path, const char* key,
                               bool required, double lo, double hi, const char* what,
                               bool lo_open = false);
  // A finite number; `expected` is the whole phrase ("a duration in s > 0"); the caller checks
  // further conditions with its own wording.
  std::optional<double> num(const nlohmann::json& o, const std::string& path, const char* key,
                            bool required, const char* expected = "a number");

  // An integer in [lo, hi] (a float such as 3.0 or 1e3 is not an integer; values beyond the
  // range, including beyond 64 bits, are errors with the range).
  std::optional<long long> integer(const nlohmann::json& o, const std::string& path,
                                   const char* key, bool required, long long lo, long long hi,
                                   const char* what);
  // An integer representable as long long; `expected` is the whole phrase ("an integer >= 1").
  std::optional<long long> integer(const nlohmann::json& o, const std::string& path,
                                   const char* key, bool required,
                                   const char* expected = "an integer");
  // An unsigned 64-bit integer (seeds).
  std::optional<unsigned long long> uint64(const nlohmann::json& o, const std::string& path,
                                           const char* key, bool required, const char* expected);

  std::optional<bool> boolean(const nlohmann::json& o, const std::string& path, const char* key,
                              bool required = false);

  // A string (may be empty), optionally one of `allowed`.
  std::optional<std::string> text(const nlohmann::json& o, const std::string& path, const char* key,
                                  bool required, std::initializer_list<const char*> allowed = {});
  // A non-empty string.
  std::optional<std::string> nonempty_text(const nlohmann::json& o, const std::string& path,
                                           const char* key, bool required);
  // A non-empty string that is one of `options`.
  std::optional<std::string> one_of(const nlohmann::json& o, const std::string& path,
                                    const char* key, bool required,
                                    const std::vector<std::string>& options);

  // [x, y, z]: three finite numbers, each in [lo, hi] (`what` names the vector and its unit).
  std::optional<std::array<double, 3>> vec3(const nlohmann::json& o, const std::string& path,
                                            const char* key, bool required, double lo, double hi,
                                            const char* what);

  // Number formatting used in messages: 0.01, 1e+06, inf.
  static std::string fmt(double x);

 private:
  bool in_range(const nlohmann::json& v, const std::string& p, double lo, double hi,
                const char* what, bool lo_open);
  std::string file_;
  std::string text_;
  mutable std::optional<JsonLocator> loc_;
  std::vector<Problem> problems_;
};

// Ids end up in file names (figures, traces, stills), database text and CSV cells, so every id
// (study, phase, group, participant, instructor, hypothesis, prototype) follows one grammar
// (docs/FORMATS.md "Ids"): 1 to 64 ASCII letters, digits, '_', '-' and '.', the first a letter
// or digit. A violation is recorded on `c` at `path`, naming the first offending character.
void check_id(Checker& c, const std::string& id, const std::string& path);

}  // namespace palplab::json
