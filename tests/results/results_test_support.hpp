#pragma once
// Helpers shared by the results-store tests: a fresh scratch directory and a whole file's bytes.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace palplab::results::test_support {

// A fresh, empty scratch directory (TMPDIR: the build's test_tmp under ctest).
inline std::filesystem::path tmp(const std::string& prefix, const std::string& name) {
  auto d = std::filesystem::temp_directory_path() /
           ("palplab_" + prefix + "_" + name + "_" + std::to_string(getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

}  // namespace palplab::results::test_support
