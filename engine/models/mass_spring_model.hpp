#pragma once
// Model "mass_spring" (prototype C): what outside the model may build of it.
#include "engine/models/model.hpp"
#include "engine/models/refinement.hpp"

namespace palplab::engine {

// The adaptive mass-spring system of a scene at rest, exactly as the model "mass_spring" builds
// it (material, support, pinned nodes, coarse surface faces; the refinement data structures
// with it): for tests and benchmarks of the refinement on a prototype's own mesh. Throws
// InputError for an unknown tissue or fixed region.
AdaptiveMassSpring mass_spring_adaptive(const SceneConfig& cfg, const SceneMesh& cm);

// Test seam: models made while this is false write their whole linear exterior every contact
// step (the eager path the lazy exterior must reproduce bit for bit; see the LazyExterior test).
// Default true.
void set_lazy_exterior(bool lazy);

}  // namespace palplab::engine
