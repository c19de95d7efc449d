#pragma once
// Builds a Scene from a prototype JSON file (docs/formats/prototypes.md). Generated meshes and
// their precomputation (rings, octree, springs) are cached per (generator, parameters), so
// building a fresh scene for every session is cheap; Scene::reset() is cheaper still.
// Bad files throw palplab::InputError located at FILE:LINE:COL and JSON path.
#include <string>

#include "engine/haptics/scene.hpp"

namespace palplab::prototypes {

engine::Scene build_scene(const std::string& prototype_json_path,
                          const engine::SceneOverrides& overrides = {});

}  // namespace palplab::prototypes
