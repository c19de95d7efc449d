#pragma once
// The located message of an InputError thrown by f (empty when none is thrown): shared by the
// analysis tests that check input errors.
#include <string>

#include "common/input_error.hpp"

template <class F>
std::string error_of(F f) {
  try {
    f();
  } catch (const palplab::InputError& e) {
    return e.what();
  }
  return {};
}
