#pragma once
// The FEM scene tests' quasi-static prototype: a shipped prototype with large steps. Backward
// Euler with h = 5 s is a damped fixed-point iteration towards the static equilibrium of the press
// (the haptic dynamics are not what these tests compare).
#include <string>

#include "engine/haptics/scene_config.hpp"
#include "prototypes/factory.hpp"
#include "tests/prototypes/prototype_text.hpp"

namespace palplab::engine::testing {

inline SceneConfig quasi_static(const std::string& id) {
  SceneConfig c = prototypes::load_prototype(proto(id));
  c.dt = 5.0;
  return c;
}

}  // namespace palplab::engine::testing
