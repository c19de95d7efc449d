#pragma once
// Helpers for protocols tests: a temporary directory with prototype files and a study file, and
// an inspector that reports the tract's region names (the engine's own inspector is exercised by
// the CLI tests, which use the real prototypes).
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "common/input_error.hpp"
#include "protocols/study.hpp"

namespace fixture {

inline std::filesystem::path temp_dir(const std::string& name) {
  auto d = std::filesystem::temp_directory_path() /
           ("palplab_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

inline void write(const std::filesystem::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

inline std::string read(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

inline palplab::protocols::PrototypeInspector tract_inspector() {
  return [](const std::string&) {
    return palplab::protocols::PrototypeInfo{
        {"ovary_left", "ovary_right", "horn_left", "horn_right", "body", "cervix"},
        "bovine_reproductive_tract"};
  };
}

// A directory with prototype stubs A, B, C, C1, C2 (valid JSON; the fake inspector supplies the
// regions) and the given study text as study.json.
inline std::string study_in_dir(const std::string& name, const std::string& study_text) {
  auto d = temp_dir(name);
  for (const char* id : {"A", "B", "C", "C1", "C2"}) write(d / (std::string(id) + ".json"), "{}");
  write(d / "study.json", study_text);
  return (d / "study.json").string();
}

inline std::string reference_study(const std::string& file) {
  return read(std::filesystem::path(PALPLAB_SOURCE_DIR) / "protocols" / "studies" / file);
}

// The problems load_study reports for the study `text` (saved as <temp>/<name>/study.json beside
// the shipped prototypes); empty when it loads.
inline std::vector<palplab::Problem> problems_of(const std::string& name, const std::string& text) {
  try {
    palplab::protocols::load_study(study_in_dir(name, text), tract_inspector());
  } catch (const palplab::InputError& e) {
    return e.problems();
  }
  return {};
}

}  // namespace fixture
