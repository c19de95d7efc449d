#pragma once
// Procedural meshes: the bovine reproductive tract (Model-A/B surfaces, the
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
#include <iterator>
#include <string>
#include <vector>

#include "engine/mesh/surface_mesh.hpp"
#include "engine/mesh/tet_mesh.hpp"
#include "engine/mesh/tetrahedralize.hpp"

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
// boundary loops. J-shaped, 0.33 m along the centreline, fundus radius 0.045 m narrowing
// to 0.012 m at the pylorus. seed != 0 perturbs the radii by up to +-5 %.
SurfaceMesh generate_stomach(std::uint64_t seed = 0);

// Geodesic (class I) icosphere of radius 0.05 m with frequency nu: 10 nu^2 + 2 vertices,
// 20 nu^2 faces. The frequency is chosen so that the vertex count is closest to
// target_vertices (642 -> nu = 8 exactly; 23522 -> nu = 48, 23042 vertices).
SurfaceMesh generate_sphere(int target_vertices = 642);
int sphere_frequency_for(int target_vertices);

// Model-C: the tract surface with surface_vertices vertices filled with a quality tet mesh by
// TetGen (issue 9): radius-edge ratio <= radius_edge (-q), a minimum dihedral angle target
// (-q<ratio>/<angle>; TetGen treats it as a goal, not a guarantee), and a maximum tet volume
// volume_factor × (volume of the regular tet whose edge is the surface's mean edge length, -a),
// so interior tets are about as large as the surface triangles. The surface is kept as generated
// (-Y: boundary faces = the surface's faces, its vertices keep their indices 0..n-1), so TetGen's
// quality bound cannot be enforced at the boundary; the levels below are chosen (seed 0) where
// it holds everywhere. Other seeds get best effort (default size, seeds 1-5: min dihedral
// 4.3-6.9°, radius-edge max 1.9-8.4, mass ratio 144-495 : 1): check with tet_quality
// (engine/mesh/info.hpp).
// Every tet has attribute 101 (soft tissue) and a named region: a tet on the boundary takes the
// region of its boundary face (the smaller id if it has two faces of different regions), an
// interior tet the majority region of its surface vertices (see tetrahedralize).
// Default (seed 0, 1604 surface vertices): 2426 nodes (822 interior), 9264 tets, 3204 boundary
// faces (the original: 2487 / 8744 / 4974 — 3.5 tets per node, a ratio only a skin mesh reaches;
// the previous generated Model-C was such a skin, with 2 interior nodes), min dihedral 7.7°,
// radius-edge <= 1.95, lumped node-mass ratio 217:1 (the old skin mesh: 36 000:1).
struct ModelCOptions {
  int surface_vertices = 1600;  // target surface vertex count (generate_tract)
  std::uint64_t seed = 0;       // generate_tract's shape seed
  double radius_edge = 2.0;     // TetGen -q bound; 0 = no quality refinement (the old skin mesh)
  double min_dihedral = 12;     // degrees, TetGen -q<ratio>/<angle>; 0 = TetGen's default
  double volume_factor = 3;     // max tet volume / regular-tet volume of the mean surface edge;
                                // 0 = no volume bound
};
inline constexpr int kModelCSurfaceVertices = ModelCOptions{}.surface_vertices;

// Resolution family for convergence studies: the same organ (same shape and seed) at four
// resolutions, each a quality mesh with the default recipe. Surface vertex targets, coarse to
// fine; level 2 is the default Model-C. Seed 0: 886 / 1689 / 2426 / 4565 nodes.
inline constexpr int kModelCLevels[] = {750, 1200, 1600, 2440};
inline constexpr int kModelCLevelCount = static_cast<int>(std::size(kModelCLevels));
// Options of level 0 .. kModelCLevelCount-1; throws InputError for another level.
ModelCOptions model_c_level(int level, std::uint64_t seed = 0);

// The -a bound used for `s`: volume_factor · L³ / (6√2), L = mean edge length of s (m^3).
double model_c_max_volume(const SurfaceMesh& s, double volume_factor);

// Throws InputError on out-of-range options (vertex count as generate_tract; radius_edge 0 or
// >= 1; min_dihedral in [0, 60); volume_factor >= 0) or when TetGen fails.
TetMesh generate_model_c(const ModelCOptions& opt);
TetMesh generate_model_c(std::uint64_t seed = 0, int surface_vertices = kModelCSurfaceVertices);

// The names of the regions of the tract, in id order.
const std::vector<std::string>& tract_region_names();

// ---- the shoulder of the needle-insertion scene (issue 16, SPEC §4)
//
// A procedural right shoulder (x lateral, y anterior, z superior; metres), made of nested closed
// surfaces written as ONE surface (several components) plus a `.regions` seed file, so that
// `palplab mesh tetrahedralize` fills it with one conforming tet mesh whose tets carry their
// tissue type. Components, outside in:
//   skin_outer   rounded box |x/a|^3 + |y/b|^3 + |z/c|^3 = 1, a = 0.075, b = 0.070, c = 0.080
//   skin_inner   the same surface moved 2 mm inwards along the ray from the origin
//   fat_inner    moved 12 mm inwards (10 mm subcutaneous fat); inside it the deltoid muscle
//   humerus      head: sphere of radius 24 mm around c_h = (0.022, 0, 0)
//   membrane     joint capsule, the target: a 2 mm thick spherical shell cap around c_h,
//                radii 25.5-27.5 mm, half angle 40° about the medial axis (-x)
//   glenoid      scapula at the joint: a shell cap around c_h, radii 29-41 mm, half angle 32°
//   acromion     scapula above the head: ellipsoid at (0.020, 0, 0.041), semi-axes 25/15/5 mm
// Gaps of 1.5 mm (muscle) separate the head, the membrane and the glenoid, so no two
// surfaces touch. Tissues (seeds): skin 100, subcutaneous fat 101 (soft tissue), deltoid 300
// (muscle), humerus 200, scapula 201 (glenoid and acromion), membrane 107.
struct ShoulderOptions {
  // Vertex target of each skin/fat layer surface (an icosphere mapped onto it: 642 coarse,
  // 2562 default); the bones and the membrane scale with it.
  int layer_vertices = 2562;
};

struct ShoulderPart {
  std::string name;    // skin_outer, skin_inner, fat_inner, humerus, membrane, glenoid, acromion
  int first_face = 0;  // the part's faces are [first_face, first_face + faces)
  int faces = 0;
  int first_vertex = 0;  // and its vertices [first_vertex, first_vertex + vertices)
  int vertices = 0;
  int parent = -1;  // the part whose surface directly encloses this one (-1: none)
  int inside = 0;   // tissue attribute just inside this surface
};

struct Shoulder {
  SurfaceMesh surface;  // all parts, outward oriented, in the order above
  std::vector<ShoulderPart> parts;
  std::vector<RegionSeed> seeds;  // one per tissue region (the .regions file)
};

// Throws InputError when layer_vertices is out of [162, 40962].
Shoulder generate_shoulder(const ShoulderOptions& opt = {});

}  // namespace palplab::mesh
