#pragma once
// Locating JSON values in their source text, so that errors in study and prototype files can be
// reported as FILE:LINE:COL: $.json.path: what was expected.
//
// nlohmann::json forgets where a value came from; JsonLocator re-scans the (already valid) text
// once and records, for every value, the position of the value and of its member key. Paths are
// written in the JSONPath subset used in all palplab messages: `$`, `$.key`, `$["odd key"]`,
// `$.groups[1].size`. JSON pointers (`/groups/1/size`) are accepted too.
//
// Lines and columns are 1-based; columns count Unicode code points (UTF-8), as editors do.
#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "common/input_error.hpp"

namespace palplab::json {

struct TextPos {
  int line = 0;      // 1-based; 0 = unknown
  int column = 0;    // 1-based, in code points
  long offset = -1;  // byte offset into the text
};

// Line and column of a byte offset (offsets past the end map to the end of the text).
TextPos offset_to_pos(std::string_view text, std::size_t offset);

// Deepest nesting of objects/arrays accepted in a palplab JSON file (they need about 6).
inline constexpr int kMaxDepth = 64;

// Byte offset of the first '{' or '[' nested deeper than kMaxDepth (strings skipped), or npos.
// For text parsed without parse_located (a line of a replicate file): nlohmann parses any depth,
// but printing or walking such a value recurses without bound.
std::size_t too_deep_at(std::string_view text);

// Parses JSON text; a syntax error becomes an InputError located at FILE:LINE:COL with what was
// expected. Duplicate member keys are an error too (nlohmann would silently keep the last), and
// so are nesting deeper than kMaxDepth and numbers that overflow a double (1e400).
// With `duplicates`, repeated keys are appended there instead of thrown (the later value is
// kept), so a validator can report them together with the file's other problems.
nlohmann::json parse_located(std::string_view text, const std::string& file,
                             std::vector<Problem>* duplicates = nullptr);

// Largest JSON file read (parse_file_located): 256 MiB, far above any study or prototype.
inline constexpr std::size_t kMaxJsonFileBytes = 256u * 1024 * 1024;

// Reads and parses a file; a missing/unreadable file, a directory or one above
// kMaxJsonFileBytes (checked while reading: /dev/zero stops there) is an InputError naming it.
nlohmann::json parse_file_located(const std::string& path, std::string* text_out = nullptr,
                                  std::vector<Problem>* duplicates = nullptr);

// Child paths in the message syntax: path_key("$", "groups") == "$.groups",
// path_key("$", "a b") == "$[\"a b\"]", path_index("$.groups", 1) == "$.groups[1]".
std::string path_key(std::string_view parent, std::string_view key);
std::string path_index(std::string_view parent, std::size_t index);

// "/groups/1/size" -> "$.groups[1].size" (RFC 6901 escapes ~0 ~1 understood). Paths that already
// start with '$' are returned unchanged.
std::string normalize_path(std::string_view path_or_pointer);

struct DuplicateKey {
  std::string path;       // path of the repeated member
  TextPos first, second;  // the key before it (the previous copy) and the repeat
};

class JsonLocator {
 public:
  // `text` must be syntactically valid JSON (parse it with parse_located first).
  explicit JsonLocator(std::string_view text);

  // Position of the value at `path`. A path that does not exist (e.g. a missing required key)
  // falls back to its nearest existing ancestor, so a message still points into the right object.
  TextPos value(std::string_view path) const;
  // Position of the member key of `path` (the value's position for array elements and `$`).
  // Use it for "unknown key" messages.
  TextPos key(std::string_view path) const;
  bool contains(std::string_view path) const;

  const std::vector<DuplicateKey>& duplicates() const { return duplicates_; }

  // A SourceLocation for palplab::Problem, pointing at the value (at_key = false) or the key.
  SourceLocation locate(const std::string& file, std::string_view path, bool at_key = false) const;

 private:
  struct Entry {
    TextPos value, key;
  };
  const Entry* find(std::string_view path) const;
  std::unordered_map<std::string, Entry> entries_;
  std::vector<DuplicateKey> duplicates_;
};

}  // namespace palplab::json
