// The validator's default view of a prototype: the engine's own inspection (file checks and the
// region names of its scene), without building the simulator.
#include "protocols/study.hpp"
#include "prototypes/factory.hpp"

namespace palplab::protocols {

PrototypeInspector engine_prototype_inspector() {
  return [](const std::string& path) {
    auto s = prototypes::inspect_prototype(path);
    return PrototypeInfo{s.region_names, s.scene, s.id, s.inner_regions, s.dt};
  };
}

}  // namespace palplab::protocols
