// The registry of model kinds: one line per kind (its file defines the entry).
#include "engine/models/model.hpp"

namespace palplab::engine {

const ModelKind& penalty_model_kind();      // penalty_model.cpp
const ModelKind& ring_model_kind();         // ring_model.cpp
const ModelKind& mass_spring_model_kind();  // mass_spring_model.cpp
const ModelKind& fem_model_kind();          // fem_scene_model.cpp
const ModelKind& needle_model_kind();       // needle_model.cpp

const std::vector<ModelKind>& model_kinds() {
  static const std::vector<ModelKind> kinds = {
      penalty_model_kind(), ring_model_kind(),   mass_spring_model_kind(),
      fem_model_kind(),     needle_model_kind(),
  };
  return kinds;
}

const ModelKind* find_model_kind(const std::string& name) {
  for (const auto& k : model_kinds())
    if (name == k.name) return &k;
  return nullptr;
}

}  // namespace palplab::engine
