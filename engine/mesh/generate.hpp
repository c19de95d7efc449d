#pragma once
// Procedural meshes (SPEC §1, §3): the bovine reproductive tract (Model-A/B surfaces, the
// surface of Model-C), the stomach tube and geodesic spheres. All sizes in metres; the output
// depends only on the arguments (same arguments -> same arrays, bit for bit).
//
// The tract is ONE closed genus-0 surface, z up along the tract, x across the horns, y front to
// back: a swept tube for cervix and body (z from 0 to 0.20 m, 5 cm wide), split at the top by a
// "pants" junction into two horns that rise and curl outwards and down, each ending in an
// ovary-shaped bulge. Overall 0.355 m tall (z), 0.145 m across the horns (x), 0.05 m deep (y).
// Face regions, in this order (ids 0..5): ovary_left, ovary_right, horn_left, horn_right, body,
// cervix. "left" is the -x side.
#include <cstdint>
#include <string>
#include <vector>

#include "engine/mesh/surface_mesh.hpp"
#include "engine/mesh/tet_mesh.hpp"

namespace palplab::mesh {

struct TractOptions {
  int target_vertices = 1500;  // the vertex count is matched within about 2 %
  // 0 = the reference shape. Any other seed perturbs horn curl, horn and ovary radii by up to
  // +-5 % (anatomical variability); sizes stay within 10 % of the reference.
  std::uint64_t seed = 0;
};

// Reference sizes: Model-A 1500 vertices / 2996 faces; Model-B 6000 / 11996.
SurfaceMesh generate_tract(const TractOptions& opt);

// Open stomach tube, 6 vertices around x 32 rings: 192 vertices, 372 faces, 564 edges, two
// boundary loops (SPEC §1). J-shaped, 0.33 m along the centreline, fundus radius 0.045 m narrowing
// to 0.012 m at the pylorus. seed != 0 perturbs the radii by up to +-5 %.
SurfaceMesh generate_stomach(std::uint64_t seed = 0);

// Geodesic (class I) icosphere of radius 0.05 m with frequency nu: 10 nu^2 + 2 vertices,
// 20 nu^2 faces. The frequency is chosen so that the vertex count is closest to
// target_vertices (642 -> nu = 8 exactly; 23522 -> nu = 48, 23042 vertices).
SurfaceMesh generate_sphere(int target_vertices = 642);
int sphere_frequency_for(int target_vertices);

// Model-C: the tract surface with surface_vertices vertices tetrahedralized by TetGen without
// Steiner points on the surface (-pY, no quality bound). The default surface size balances the
// three reference counts (SPEC: 2487 nodes, 8744 tets, 4974 boundary faces): the reference shape
// gives 2410 nodes (TetGen adds none inside), 9223 tets, 4816 boundary faces — all within 6 %.
// (A surface of 2487 vertices would give about 9400 tets: a surface-only tetrahedralization of
// this shape has about 3.8 tets per node where the original had 3.5.) Every tet has attribute
// 101 (soft tissue) and the named region carried over from the surface.
inline constexpr int kModelCSurfaceVertices = 2420;
TetMesh generate_model_c(std::uint64_t seed = 0, int surface_vertices = kModelCSurfaceVertices);

// The names of the regions of the tract, in id order.
const std::vector<std::string>& tract_region_names();

}  // namespace palplab::mesh
