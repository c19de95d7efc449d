#pragma once
// Helpers shared by the fuzz entry files (not part of the entry API).
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "common/input_error.hpp"

namespace palplab::fuzz::detail {

namespace fs = std::filesystem;

// A private scratch directory per process (the mesh and prototype readers take paths).
inline fs::path base_dir() {
  fs::path base = fs::exists("/dev/shm") ? fs::path("/dev/shm") : fs::temp_directory_path();
  return base / ("palplab_fuzz_" + std::to_string(::getpid()));
}

inline const fs::path& scratch() {
  static const fs::path d = [] {
    fs::path p = base_dir();
    fs::create_directories(p);
    std::atexit([] {  // leave nothing behind in /dev/shm
      std::error_code ec;
      fs::remove_all(base_dir(), ec);
    });
    return p;
  }();
  return d;
}

inline std::string write(const std::string& name, std::string_view bytes) {
  const fs::path p = scratch() / name;
  std::ofstream(p, std::ios::binary | std::ios::trunc).write(bytes.data(), bytes.size());
  return p.string();
}

inline std::string_view view(const std::uint8_t* d, std::size_t n) {
  return {reinterpret_cast<const char*>(d), n};
}

template <class F>
void expect_input_errors_only(F&& f) {
  try {
    f();
  } catch (const palplab::InputError&) {
    // the one allowed failure: a located message and exit 2 on the command line
  }
}

}  // namespace palplab::fuzz::detail
