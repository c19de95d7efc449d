#pragma once
// Builds a Scene from a prototype JSON file (docs/FORMATS.md). Generated meshes and
// their precomputation (normals, regions, rings, octree) are cached per process and mesh
// description, so building a fresh scene for every session is cheap; Scene::reset() is cheaper
// still. Thread-safe (the cache is locked). Bad files throw palplab::InputError located at
// FILE:LINE:COL and JSON path, listing every problem found.
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "engine/haptics/scene_config.hpp"

namespace palplab::json {
class Checker;
}

namespace palplab::prototypes {

// Reads and validates a prototype file into the scene configuration (every problem located at
// FILE:LINE:COL and JSON path, thrown together as one InputError). Edit the result for a variant
// and build it with engine::make_scene.
engine::SceneConfig load_prototype(const std::string& prototype_json_path);

// = make_scene(load_prototype(path) with the study phase's overrides applied).
engine::Scene build_scene(const std::string& prototype_json_path,
                          const engine::SceneOverrides& overrides = {});

// The force limits of one region, {"ST", "MPF", "SFT"} in N (the spelling of study files too).
engine::Thresholds read_thresholds(json::Checker& c, const nlohmann::json& o,
                                   const std::string& path);

// Validates a prototype file without building the simulator and returns what a study needs to
// know of it. Region names come from the mesh generator (no mesh is generated).
struct PrototypeSummary {
  std::string id;     // "A", "C1", ...
  std::string scene;  // e.g. "bovine_reproductive_tract"
  std::string model;  // a registered model kind: "penalty", "ring", "mass_spring", "fem", ...
  std::vector<std::string> region_names;
  std::vector<std::string>
      inner_regions;  // regions with no surface vertex (mesh_inner_region_names)
  double dt = 0.0;    // s, the haptic step
};
PrototypeSummary inspect_prototype(const std::string& prototype_json_path);

}  // namespace palplab::prototypes
