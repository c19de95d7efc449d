#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include "common/input_error.hpp"
#include "engine/mesh/generate.hpp"
#include "engine/mesh/io.hpp"
#include "engine/mesh/tetrahedralize.hpp"

namespace palplab::mesh {

namespace {

std::array<int, 3> sorted_face(int a, int b, int c) {
  std::array<int, 3> f{a, b, c};
  std::sort(f.begin(), f.end());
  return f;
}

// Gives every tet that owns a boundary face the region of that face of the input surface (with
// -Y the boundary faces are the surface's faces), so the regions the participant sees on the
// surface are exactly the generated ones. A tet with boundary faces of two regions takes the
// smaller id.
void boundary_regions_from_surface(TetMesh& m, const SurfaceMesh& s) {
  if (s.regions.empty() || m.regions.empty()) return;
  std::map<std::array<int, 3>, int> face_region;
  for (int f = 0; f < s.F.rows(); ++f)
    face_region.emplace(sorted_face(s.F(f, 0), s.F(f, 1), s.F(f, 2)), s.regions.id[f]);
  const BoundaryFaces b = boundary_faces(m);
  std::vector<int> region(m.T.rows(), -1);
  for (int f = 0; f < b.F.rows(); ++f) {
    const auto it = face_region.find(sorted_face(b.F(f, 0), b.F(f, 1), b.F(f, 2)));
    if (it == face_region.end()) continue;  // cannot happen with -Y; keep the voted region
    int& r = region[b.tet[f]];
    r = r < 0 ? it->second : std::min(r, it->second);
  }
  for (int t = 0; t < m.T.rows(); ++t)
    if (region[t] >= 0) m.regions.id[t] = region[t];
}

}  // namespace

ModelCOptions model_c_level(int level, std::uint64_t seed) {
  if (level < 0 || level >= kModelCLevelCount)
    throw InputError("Model-C level must be 0.." + std::to_string(kModelCLevelCount - 1) +
                     ", got " + std::to_string(level));
  ModelCOptions o;
  o.surface_vertices = kModelCLevels[level];
  o.seed = seed;
  return o;
}

double model_c_max_volume(const SurfaceMesh& s, double volume_factor) {
  if (s.E.rows() == 0) return 0;
  double sum = 0;
  for (int e = 0; e < s.E.rows(); ++e) sum += (s.V.row(s.E(e, 0)) - s.V.row(s.E(e, 1))).norm();
  const double L = sum / static_cast<double>(s.E.rows());
  return volume_factor * L * L * L / (6 * std::sqrt(2.0));
}

TetMesh generate_model_c(const ModelCOptions& opt) {
  if (!(opt.radius_edge == 0 || opt.radius_edge >= 1.0) || !std::isfinite(opt.radius_edge))
    throw InputError("Model-C radius-edge bound must be 0 (off) or >= 1.0, got " +
                     format_exact(opt.radius_edge));
  if (!(opt.min_dihedral >= 0 && opt.min_dihedral < 60))
    throw InputError("Model-C minimum dihedral angle must be in [0, 60) degrees, got " +
                     format_exact(opt.min_dihedral));
  if (!(opt.volume_factor >= 0) || !std::isfinite(opt.volume_factor))
    throw InputError("Model-C volume factor must be >= 0, got " + format_exact(opt.volume_factor));
  const SurfaceMesh s = generate_tract({opt.surface_vertices, opt.seed});
  TetOptions o;
  o.default_attribute = 101;  // soft tissue
  o.keep_surface = true;
  o.quality = opt.radius_edge;
  o.min_dihedral = opt.radius_edge > 0 ? opt.min_dihedral : 0;
  o.max_volume = model_c_max_volume(s, opt.volume_factor);
  TetMesh m = tetrahedralize(s, o);
  boundary_regions_from_surface(m, s);
  return m;
}

TetMesh generate_model_c(std::uint64_t seed, int surface_vertices) {
  ModelCOptions o;
  o.seed = seed;
  o.surface_vertices = surface_vertices;
  return generate_model_c(o);
}

}  // namespace palplab::mesh
