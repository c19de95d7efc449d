#pragma once
// Mesh defects that stop tetrahedralization or simulation, each located by indices and
// coordinates. Kinds (the JSON contract of `palplab mesh check`):
//   open_edge                 edge with one face where a closed surface is expected
//   non_manifold_edge         edge with more than two faces
//   non_manifold_vertex       vertex whose faces form more than one fan
//   duplicate_vertex          two vertices closer than the tolerance
//   degenerate_face           repeated vertex index or (near) zero area
//   inconsistent_orientation  edge traversed in the same direction by its two faces
//   self_intersection         two non-adjacent triangles (or two sharing only a vertex) crossing
//   inverted_tet              tet with negative signed volume
//   sliver_tet                tet with radius ratio below the threshold (includes zero volume)
//   non_finite_vertex         vertex with a NaN or infinite coordinate (the geometric checks
//                             above are skipped then: they mean nothing on such coordinates)
//   empty_mesh                no faces (surfaces) or no tets (tet meshes)
//   inside_out                a closed part of a surface whose normals point inwards
//   duplicate_tet             two tets of the same four nodes (tets: both indices)
//   unused_vertex             a node of a tet mesh that no tet uses
#include <map>
#include <string>
#include <vector>

#include "engine/mesh/surface_mesh.hpp"
#include "engine/mesh/tet_mesh.hpp"

namespace palplab::mesh {

struct Defect {
  std::string kind;
  std::vector<int> vertices;  // vertex indices involved
  std::vector<int> faces;     // face indices involved (surfaces)
  std::vector<int> tets;      // tet indices involved (tet meshes)
  std::vector<Vec3> points;   // where: vertex positions, an intersection point, a centroid (m)
  double value = 0;           // kind-specific: area (m^2), distance (m), radius ratio, volume
};

struct CheckOptions {
  bool expect_closed = true;          // report boundary edges as open_edge
  double duplicate_tolerance = 1e-9;  // m: vertices closer than this are duplicates
  // A face is degenerate when 2·area <= degenerate_ratio · (longest edge)^2, i.e. its height is
  // below that fraction of its longest edge (or it repeats a vertex).
  double degenerate_ratio = 1e-10;
  // Radius ratio (3 r_in / R_circ, 1 = regular) below which a tet is a sliver. The default flags
  // only numerically degenerate tets; use ~0.1 for a strict quality audit.
  double sliver_ratio = 1e-4;
  bool self_intersections = true;
  int max_per_kind = 1000;  // defects listed per kind (all are counted)
};

struct CheckReport {
  std::vector<Defect> defects;
  std::map<std::string, long> counts;  // all defects found per kind (defects may be truncated)
  bool truncated = false;
  bool clean() const { return counts.empty(); }
};

const std::vector<std::string>& defect_kinds();

CheckReport check_surface(const SurfaceMesh& m, const CheckOptions& opt = {});

// Twice the area of triangle (a, b, c) over its longest edge squared (0 for a repeated point);
// `degenerate_ratio` compares against it. Computed on edges scaled by their largest component,
// so it is the same at 1e-300 and 1e300 (check and repair share it).
double triangle_flatness(const Vec3& a, const Vec3& b, const Vec3& c);
// The triangle's area (m^2), from the scaled edges (inf only when the area itself overflows).
double triangle_area(const Vec3& a, const Vec3& b, const Vec3& c);

// A closed, consistently oriented part of a surface (faces linked through consistent edges).
struct SurfacePart {
  std::vector<int> faces;  // ascending
  double volume = 0;       // enclosed signed volume (m^3), < 0 when the normals point inwards
};
// The parts that are inside out: negative volume and no cavity (a hollow body's inner shell
// points into the cavity by right; a part is one when its first face's centroid lies inside
// the other closed parts, their winding number there >= 1/2). `mesh check` reports them,
// `mesh repair` reverses them. The coordinates must be finite.
std::vector<SurfacePart> inside_out_parts(const SurfaceMesh& m);
// Tets (inverted, sliver), duplicate vertices and the manifoldness of the boundary surface.
CheckReport check_tets(const TetMesh& m, const CheckOptions& opt = {});

// Pairs of duplicate vertices (i < j, |Vi - Vj| <= tol), found through a hash grid in O(n).
std::vector<std::pair<int, int>> duplicate_vertex_pairs(const Positions& V, double tol);
// Self-intersecting triangle pairs (f < g) through a BVH; `points` gets one crossing point each.
std::vector<std::pair<int, int>> self_intersections(const Positions& V, const Faces& F,
                                                    std::vector<Vec3>* points = nullptr);
// The same by testing all pairs: the O(n^2) baseline, for tests only.
std::vector<std::pair<int, int>> self_intersections_brute_force(const Positions& V, const Faces& F);

}  // namespace palplab::mesh
