#pragma once
// Prototype files as text for the physics tests: a shipped prototype's path, a file's text, and
// a variant of a prototype's text (string edits) written to a temp file that build_scene reads.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

namespace palplab::engine::testing {

inline std::string proto(const std::string& id) {
  return std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + id + ".json";
}

inline std::string read(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// `text` with every (from -> to) replaced once (each must occur: a failed expectation names the
// missing one), written to <temp>/palplab_<file_tag>_<pid>.json; returns that path. ctest runs
// each test in its own process, in parallel: the pid keeps two tests of one file (same tag) from
// writing and reading one file at the same time.
inline std::string variant_file(std::string text, const std::string& file_tag,
                                const std::vector<std::pair<std::string, std::string>>& edits) {
  for (const auto& [from, to] : edits) {
    const auto k = text.find(from);
    EXPECT_NE(k, std::string::npos) << from;
    if (k != std::string::npos) text.replace(k, from.size(), to);
  }
  const auto p = std::filesystem::temp_directory_path() /
                 ("palplab_" + file_tag + "_" + std::to_string(::getpid()) + ".json");
  std::ofstream(p) << text;
  return p.string();
}

}  // namespace palplab::engine::testing
