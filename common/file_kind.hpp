#pragma once
// palplab's own binary files, told by their first bytes: where a text input (JSON, JSON lines) or
// an output's earlier file is found to be one of them, messages name it instead of a parse error.
#include <string_view>

namespace palplab {

// "a palplab scene file (.psim)", "an SQLite database" or nullptr for any other start.
inline const char* binary_file_kind(std::string_view head) {
  if (head.starts_with(std::string_view("PALPSIM\0", 8))) return "a palplab scene file (.psim)";
  if (head.starts_with(std::string_view("SQLite format 3\0", 16))) return "an SQLite database";
  return nullptr;
}

}  // namespace palplab
