#include "engine/mesh/generate.hpp"
#include "engine/mesh/tetrahedralize.hpp"

namespace palplab::mesh {

TetMesh generate_model_c(std::uint64_t seed, int surface_vertices) {
  const SurfaceMesh s = generate_tract({surface_vertices, seed});
  TetOptions o;
  o.default_attribute = 101;  // SPEC §4: soft tissue
  o.keep_surface = true;
  return tetrahedralize(s, o);
}

}  // namespace palplab::mesh
