#pragma once
// Helpers shared by the analysis tests: the located message of an InputError, a relative
// comparison, a file's text.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "common/input_error.hpp"

// The located message of an InputError thrown by f (empty when none is thrown).
template <class F>
std::string error_of(F f) {
  try {
    f();
  } catch (const palplab::InputError& e) {
    return e.what();
  }
  return {};
}

// |got - want| <= tol * |want|, named `what` in the failure.
inline void expect_rel(double got, double want, double tol, const std::string& what = {}) {
  EXPECT_LE(std::abs(got - want), tol * std::abs(want))
      << what << ": got " << got << " want " << want;
}

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
