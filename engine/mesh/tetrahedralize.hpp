#pragma once
// Tetrahedralization of a closed surface through TetGen 1.5 (libtet, in a child process).
#include <string>
#include <vector>

#include "engine/mesh/surface_mesh.hpp"
#include "engine/mesh/tet_mesh.hpp"

namespace palplab::mesh {

// One line of a `.regions` file: `index x y z region_id attribute`.
// (x, y, z) is a point inside the region; region_id becomes the attribute (tissue type,
// table) of every tet of the region; `attribute` is TetGen's region attribute, the maximum tet
// volume in that region (m^3; <= 0 = no constraint), as in TetGen's .poly region list.
struct RegionSeed {
  int index = 0;
  Vec3 point = Vec3::Zero();
  int region_id = 0;
  double max_volume = 0;
  int line = 0;  // line in the .regions file it was read from (0 = not read from a file)
};

// Reads a `.regions` file: first line the count, then one seed per line ('#' starts a comment).
// Throws InputError with file and line on malformed input.
std::vector<RegionSeed> read_region_seeds(const std::string& path);
void write_region_seeds(const std::string& path, const std::vector<RegionSeed>& seeds);

struct TetOptions {
  // Radius-edge ratio bound (TetGen -q); 0 = no quality refinement (no Steiner points added for
  // quality). TetGen accepts values >= about 1.0; 1.414 is its default when -q is given alone.
  double quality = 0;
  // Minimum dihedral angle bound (degrees, TetGen -q<ratio>/<angle>); 0 = TetGen's default
  // (no bound beyond its sliver removal). Used only with quality > 0; TetGen does not guarantee
  // it (it removes slivers by local optimisation), so check the result.
  double min_dihedral = 0;
  double max_volume = 0;          // global maximum tet volume (m^3, TetGen -a); 0 = none
  bool keep_surface = true;       // TetGen -Y: no Steiner points on the input surface
  std::vector<RegionSeed> seeds;  // TetGen -A regions; without seeds every tet gets
  int default_attribute = 0;      //   this attribute; with seeds, the tets of closed regions
                                  //   without a seed get it (0-99 = undefined tissue)
  std::string regions_file;       // where `seeds` were read from (for messages); may be empty
  double timeout_seconds = 300;   // wall-clock limit of the TetGen run; <= 0 = none
};

// What TetGen needs from its input, checked before it runs: at least 4 vertices and faces, finite
// coordinates, a sane extent, and none of the defects of `mesh check` that TetGen cannot take
// (open/non-manifold edges and vertices, duplicate vertices, degenerate faces, self-intersections
// including duplicated and coincident triangles). Throws InputError naming the first defect.
void check_tetgen_input(const SurfaceMesh& s);

// Checks that every seed point lies inside the closed surface `s` (generalized winding number of
// each connected component); otherwise an InputError names the seed (and `source`:line when
// given). tetrahedralize() runs it after check_tetgen_input (TetGen crashes on such seeds).
void check_region_seeds_inside(const SurfaceMesh& s, const std::vector<RegionSeed>& seeds,
                               const std::string& source = "");

// Tetrahedralizes the closed surface `s`. The input vertices keep their indices (Steiner points
// are appended). The surface's named face regions carry over to the tets: a tet takes the region
// held by most of its surface vertices (ties -> smaller id), or, when it touches no surface
// vertex, the region of the surface vertex nearest to its centroid.
// Throws InputError when the surface fails check_tetgen_input or TetGen rejects it. TetGen runs
// in a forked child process: its crash, abort or timeout becomes an InputError, never the end
// of the calling process.
TetMesh tetrahedralize(const SurfaceMesh& s, const TetOptions& opt = {});

// The TetGen switches used for opt (for reports): e.g. "pzQY q1.414 a1e-06 A".
std::string tetgen_switches(const TetOptions& opt);

}  // namespace palplab::mesh
