#include "engine/mesh/check.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <unordered_map>

#include "engine/mesh/union_find.hpp"
#include "engine/spatial/bvh.hpp"

// Shewchuk's robust predicates, compiled into TetGen's library (libtet): tetgen.h declares
// exactinit and orient3d; orient2d is exported alongside them without a declaration.
#include <tetgen.h>
REAL orient2d(REAL* pa, REAL* pb, REAL* pc);

namespace palplab::mesh {

const std::vector<std::string>& defect_kinds() {
  static const std::vector<std::string> k{
      "open_edge",         "non_manifold_edge", "non_manifold_vertex",
      "duplicate_vertex",  "degenerate_face",   "inconsistent_orientation",
      "self_intersection", "inverted_tet",      "sliver_tet",
      "non_finite_vertex", "empty_mesh",        "inside_out",
      "duplicate_tet",     "unused_vertex"};
  return k;
}

namespace {

void add(CheckReport& r, const CheckOptions& o, Defect d) {
  long& n = r.counts[d.kind];
  ++n;
  if (n <= o.max_per_kind)
    r.defects.push_back(std::move(d));
  else
    r.truncated = true;
}

// The orientation predicates are Shewchuk's adaptive exact ones (as exported by TetGen's
// library, which meshes what passes this check): a plain floating-point determinant has a random
// sign when the four points are coplanar up to round-off, and reports spurious crossings
// between neighbouring triangles of a subdivided planar face (midpoints a few ulp off the
// plane: e.g. the surface grading of the FEM reference, engine/models/fem_refine.hpp).
void init_exact_predicates() {
  // noexact = 0, nofilter = 1: the adaptive predicates without TetGen's static filter (whose
  // bound depends on the coordinates' range), so the bounds passed are not used.
  static const bool done = [] {
    exactinit(0, 0, 1, 1.0, 1.0, 1.0);
    return true;
  }();
  (void)done;
}

// (b - a) . ((c - a) x (d - a)), exactly signed.
double orient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  init_exact_predicates();
  Vec3 pa = a, pb = b, pc = c, pd = d;
  return -::orient3d(pa.data(), pb.data(), pc.data(), pd.data());
}

// Segment pq crosses the interior of triangle abc (strictly; touching and coplanar cases are not
// counted). On success *x is the crossing point.
bool segment_crosses(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c,
                     Vec3* x) {
  const double s1 = orient(a, b, c, p), s2 = orient(a, b, c, q);
  if (!((s1 > 0 && s2 < 0) || (s1 < 0 && s2 > 0))) return false;
  const double o1 = orient(p, q, a, b), o2 = orient(p, q, b, c), o3 = orient(p, q, c, a);
  if (!((o1 > 0 && o2 > 0 && o3 > 0) || (o1 < 0 && o2 < 0 && o3 < 0))) return false;
  if (x) *x = p + (q - p) * (s1 / (s1 - s2));
  return true;
}

double orient2(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  init_exact_predicates();
  Eigen::Vector2d pa = a, pb = b, pc = c;
  return ::orient2d(pa.data(), pb.data(), pc.data());
}

bool strictly_inside(const Eigen::Vector2d& p, const Eigen::Vector2d* t) {
  const double a = orient2(t[0], t[1], p), b = orient2(t[1], t[2], p), c = orient2(t[2], t[0], p);
  return (a > 0 && b > 0 && c > 0) || (a < 0 && b < 0 && c < 0);
}

// Two triangles in one plane (no shared vertex) overlap: an edge pair crosses properly or a
// corner of one lies strictly inside the other. Projected on the plane's dominant axis.
bool coplanar_overlap(const Vec3* A, const Vec3* B, Vec3* x) {
  const Vec3 n = (A[1] - A[0]).cross(A[2] - A[0]);
  int drop;
  n.cwiseAbs().maxCoeff(&drop);
  const int u = (drop + 1) % 3, v = (drop + 2) % 3;
  Eigen::Vector2d a[3], b[3];
  for (int k = 0; k < 3; ++k) {
    a[k] = {A[k][u], A[k][v]};
    b[k] = {B[k][u], B[k][v]};
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const double o1 = orient2(a[i], a[(i + 1) % 3], b[j]);
      const double o2 = orient2(a[i], a[(i + 1) % 3], b[(j + 1) % 3]);
      const double o3 = orient2(b[j], b[(j + 1) % 3], a[i]);
      const double o4 = orient2(b[j], b[(j + 1) % 3], a[(i + 1) % 3]);
      if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) &&
          ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0))) {
        if (x) *x = A[i] + (A[(i + 1) % 3] - A[i]) * (o3 / (o3 - o4));
        return true;
      }
    }
  for (int k = 0; k < 3; ++k) {
    if (strictly_inside(b[k], a)) {
      if (x) *x = B[k];
      return true;
    }
    if (strictly_inside(a[k], b)) {
      if (x) *x = A[k];
      return true;
    }
  }
  return false;
}

bool triangles_cross(const Positions& V, const Faces& F, int f, int g, Vec3* x) {
  int shared = 0, sf = -1, sg = -1;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (F(f, i) == F(g, j)) {
        ++shared;
        sf = i;
        sg = j;
      }
  if (shared >= 2) return false;  // neighbours across an edge (folds are orientation issues)
  const Vec3 A[3] = {row3(V, F(f, 0)), row3(V, F(f, 1)), row3(V, F(f, 2))};
  const Vec3 B[3] = {row3(V, F(g, 0)), row3(V, F(g, 1)), row3(V, F(g, 2))};
  if (shared == 1) {
    // Triangles meeting at one vertex cross iff the edge opposite it in one crosses the other.
    return segment_crosses(A[(sf + 1) % 3], A[(sf + 2) % 3], B[0], B[1], B[2], x) ||
           segment_crosses(B[(sg + 1) % 3], B[(sg + 2) % 3], A[0], A[1], A[2], x);
  }
  for (int k = 0; k < 3; ++k) {
    if (segment_crosses(A[k], A[(k + 1) % 3], B[0], B[1], B[2], x)) return true;
    if (segment_crosses(B[k], B[(k + 1) % 3], A[0], A[1], A[2], x)) return true;
  }
  // Exactly coplanar triangles (e.g. overlapping copies in CAD exports) need a 2D test.
  if (orient(A[0], A[1], A[2], B[0]) == 0 && orient(A[0], A[1], A[2], B[1]) == 0 &&
      orient(A[0], A[1], A[2], B[2]) == 0)
    return coplanar_overlap(A, B, x);
  return false;
}

}  // namespace

std::vector<std::pair<int, int>> duplicate_vertex_pairs(const Positions& V, double tol) {
  std::vector<std::pair<int, int>> out;
  if (tol < 0 || V.rows() == 0) return out;
  // Cells no smaller than the tolerance (so neighbours cover it) nor than 1e-12 of the
  // coordinates (so cell indices cannot overflow).
  // (Over the finite vertices only: one NaN vertex must not shrink the cells of the others to a
  // size whose indices overflow.)
  double scale = 0;
  for (int i = 0; i < V.rows(); ++i)
    if (V.row(i).allFinite()) scale = std::max(scale, V.row(i).cwiseAbs().maxCoeff());
  const double cell = std::max({tol, 1e-12 * scale, 1e-300});
  auto key = [&](long x, long y, long z) {
    return static_cast<std::uint64_t>(x) * 73856093ULL ^
           static_cast<std::uint64_t>(y) * 19349663ULL ^
           static_cast<std::uint64_t>(z) * 83492791ULL;
  };
  std::unordered_map<std::uint64_t, std::vector<int>> grid;
  grid.reserve(V.rows() * 2);
  auto cell_of = [&](int i, int a) { return static_cast<long>(std::floor(V(i, a) / cell)); };
  for (int i = 0; i < V.rows(); ++i) {
    if (!V.row(i).allFinite()) continue;
    const long cx = cell_of(i, 0), cy = cell_of(i, 1), cz = cell_of(i, 2);
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy)
        for (long dz = -1; dz <= 1; ++dz) {
          auto it = grid.find(key(cx + dx, cy + dy, cz + dz));
          if (it == grid.end()) continue;
          for (int j : it->second)
            // stableNorm: at 1e-300 the squares underflow and distinct points were 0 apart.
            if ((V.row(i) - V.row(j)).stableNorm() <= tol) out.push_back({j, i});
        }
    grid[key(cx, cy, cz)].push_back(i);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::vector<std::pair<int, int>> self_intersections(const Positions& V, const Faces& F,
                                                    std::vector<Vec3>* points) {
  const auto boxes = spatial::triangle_boxes(V, F);
  const spatial::Bvh bvh = spatial::build_bvh(boxes, 4);
  std::vector<std::pair<int, int>> out;
  for (auto [f, g] : spatial::overlapping_pairs(bvh, boxes)) {
    Vec3 x;
    if (triangles_cross(V, F, f, g, &x)) {
      out.push_back({f, g});
      if (points) points->push_back(x);
    }
  }
  return out;
}

std::vector<std::pair<int, int>> self_intersections_brute_force(const Positions& V,
                                                                const Faces& F) {
  std::vector<std::pair<int, int>> out;
  for (int f = 0; f < F.rows(); ++f)
    for (int g = f + 1; g < F.rows(); ++g)
      if (triangles_cross(V, F, f, g, nullptr)) out.push_back({f, g});
  return out;
}

namespace {

// One non_finite_vertex defect per vertex with a NaN/inf coordinate; true when there is any.
bool report_non_finite(CheckReport& r, const CheckOptions& o, const Positions& V) {
  bool any = false;
  for (int v = 0; v < V.rows(); ++v)
    if (!V.row(v).allFinite()) {
      add(r, o, {"non_finite_vertex", {v}, {}, {}, {row3(V, v)}, 0});
      any = true;
    }
  return any;
}

}  // namespace

namespace {
// The edges of a triangle divided by their largest component (1 when they are all 0 or not
// finite), and that divisor: areas and lengths computed from them neither overflow at 1e300 nor
// underflow at 1e-300.
struct ScaledEdges {
  Vec3 ab, ac, bc;
  double s;
};
ScaledEdges scaled_edges(const Vec3& a, const Vec3& b, const Vec3& c) {
  ScaledEdges e{b - a, c - a, c - b, 1};
  const double s = std::max(
      {e.ab.cwiseAbs().maxCoeff(), e.ac.cwiseAbs().maxCoeff(), e.bc.cwiseAbs().maxCoeff()});
  if (s > 0 && std::isfinite(s)) {
    e.ab /= s;
    e.ac /= s;
    e.bc /= s;
    e.s = s;
  }
  return e;
}
}  // namespace

double triangle_flatness(const Vec3& a, const Vec3& b, const Vec3& c) {
  const ScaledEdges e = scaled_edges(a, b, c);
  const double lmax = std::max({e.ab.squaredNorm(), e.ac.squaredNorm(), e.bc.squaredNorm()});
  return lmax > 0 ? e.ab.cross(e.ac).norm() / lmax : 0.0;
}

double triangle_area(const Vec3& a, const Vec3& b, const Vec3& c) {
  const ScaledEdges e = scaled_edges(a, b, c);
  return e.ab.cross(e.ac).norm() / 2 * e.s * e.s;
}

std::vector<SurfacePart> inside_out_parts(const SurfaceMesh& m) {
  const Faces& F = m.F;
  const int nf = static_cast<int>(F.rows());
  auto P = [&](int v) { return row3(m.V, v); };
  std::vector<int> parent(nf);
  for (int f = 0; f < nf; ++f) parent[f] = f;
  for (int h = 0; h < 3 * nf; ++h)
    if (m.twin[h] >= 0)
      parent[detail::find_root(parent, h / 3)] = detail::find_root(parent, m.twin[h] / 3);
  std::vector<int> part(nf), first(nf, -1);
  std::vector<char> open(nf, 0);
  std::vector<double> volume(nf, 0.0);
  // Volumes on coordinates divided by the mesh's largest extent (the sign at 1e300 and 1e-120
  // was lost to overflow and underflow), scaled back when reported.
  double s = 0;
  for (int v = 0; v < m.V.rows(); ++v)
    s = std::max(s, (m.V.row(v) - m.V.row(0)).cwiseAbs().maxCoeff());
  const double u = s > 0 && std::isfinite(s) ? 1 / s : 1;
  for (int f = 0; f < nf; ++f) {
    const int c = part[f] = detail::find_root(parent, f);
    if (first[c] < 0) first[c] = f;
    for (int k = 0; k < 3; ++k) open[c] |= m.twin[3 * f + k] < 0;
    // Relative to the part's first vertex (exact for a closed part, better conditioned).
    const Vec3 o = P(F(first[c], 0));
    volume[c] += ((P(F(f, 0)) - o) * u).dot(((P(F(f, 1)) - o) * u).cross((P(F(f, 2)) - o) * u)) / 6;
  }
  // Winding number at x of the closed parts other than `skip`: the sum of their faces' solid
  // angles (Van Oosterom & Strackee 1983) over 4π.
  const auto winding = [&](const Vec3& x, int skip) {
    double w = 0;
    for (int f = 0; f < nf; ++f) {
      if (part[f] == skip || open[part[f]]) continue;
      const Vec3 a = P(F(f, 0)) - x, b = P(F(f, 1)) - x, c = P(F(f, 2)) - x;
      const double la = a.norm(), lb = b.norm(), lc = c.norm();
      w += 2 * std::atan2(a.dot(b.cross(c)),
                          la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la);
    }
    return w / (4 * M_PI);
  };
  std::vector<SurfacePart> out;
  for (int c = 0; c < nf; ++c) {
    if (first[c] < 0 || open[c] || !(volume[c] < 0)) continue;
    const int f = first[c];
    if (winding((P(F(f, 0)) + P(F(f, 1)) + P(F(f, 2))) / 3, c) >= 0.5) continue;  // a cavity
    SurfacePart p;
    p.volume = volume[c] / (u * u * u);
    for (int g = f; g < nf; ++g)
      if (part[g] == c) p.faces.push_back(g);
    out.push_back(std::move(p));
  }
  return out;
}

CheckReport check_surface(const SurfaceMesh& m, const CheckOptions& o) {
  CheckReport r;
  const Positions& V = m.V;
  const Faces& F = m.F;
  auto P = [&](int v) { return row3(V, v); };
  if (F.rows() == 0) add(r, o, {"empty_mesh", {}, {}, {}, {}, static_cast<double>(V.rows())});
  // Geometry on NaN/inf coordinates means nothing (and hashing them is undefined): only the
  // topological checks run then.
  const bool geometric = !report_non_finite(r, o, V);
  // Per edge, its faces (for locating edge defects).
  // Faces of the edges that will be reported (one pass over the half-edges).
  std::vector<char> report(m.E.rows(), 0);
  for (int e = 0; e < m.E.rows(); ++e) report[e] = m.edge_faces[e] != 2;
  for (int e : m.inconsistent_edges) report[e] = 1;
  std::vector<std::vector<int>> edge_faces(m.E.rows());
  for (int h = 0; h < 3 * F.rows(); ++h)
    if (report[m.he_edge[h]]) edge_faces[m.he_edge[h]].push_back(h / 3);
  for (int e = 0; e < m.E.rows(); ++e) {
    const int a = m.E(e, 0), b = m.E(e, 1);
    if (m.edge_faces[e] == 1 && o.expect_closed)
      add(r, o, {"open_edge", {a, b}, edge_faces[e], {}, {P(a), P(b)}, (P(a) - P(b)).norm()});
    if (m.edge_faces[e] > 2)
      add(r, o,
          {"non_manifold_edge", {a, b}, edge_faces[e], {}, {P(a), P(b)}, double(m.edge_faces[e])});
  }
  for (int v : m.non_manifold_vertices) add(r, o, {"non_manifold_vertex", {v}, {}, {}, {P(v)}, 0});
  if (geometric)
    for (auto [i, j] : duplicate_vertex_pairs(V, o.duplicate_tolerance))
      add(r, o, {"duplicate_vertex", {i, j}, {}, {}, {P(i), P(j)}, (P(i) - P(j)).stableNorm()});
  for (int f = 0; geometric && f < F.rows(); ++f) {
    const int a = F(f, 0), b = F(f, 1), c = F(f, 2);
    if (a == b || b == c || a == c || triangle_flatness(P(a), P(b), P(c)) <= o.degenerate_ratio)
      add(r, o,
          {"degenerate_face",
           {a, b, c},
           {f},
           {},
           {(P(a) + P(b) + P(c)) / 3},
           triangle_area(P(a), P(b), P(c))});
  }
  for (int e : m.inconsistent_edges) {
    const int a = m.E(e, 0), b = m.E(e, 1);
    add(r, o, {"inconsistent_orientation", {a, b}, edge_faces[e], {}, {P(a), P(b)}, 0});
  }
  // Consistent, so no edge shows it, but every normal and the inside and outside of the part
  // are the wrong way round (it was "clean" while `info` gave a negative volume).
  if (geometric && o.expect_closed)
    for (const SurfacePart& p : inside_out_parts(m)) {
      const int f = p.faces.front();
      add(r, o,
          {"inside_out",
           {F(f, 0), F(f, 1), F(f, 2)},
           {f},
           {},
           {(P(F(f, 0)) + P(F(f, 1)) + P(F(f, 2))) / 3},
           p.volume});
    }
  if (o.self_intersections && geometric) {
    std::vector<Vec3> pts;
    auto pairs = self_intersections(V, F, &pts);
    for (size_t i = 0; i < pairs.size(); ++i) {
      auto [f, g] = pairs[i];
      add(r, o,
          {"self_intersection",
           {F(f, 0), F(f, 1), F(f, 2), F(g, 0), F(g, 1), F(g, 2)},
           {f, g},
           {},
           {pts[i]},
           0});
    }
  }
  return r;
}

CheckReport check_tets(const TetMesh& m, const CheckOptions& o) {
  CheckReport r;
  if (m.T.rows() == 0) add(r, o, {"empty_mesh", {}, {}, {}, {}, static_cast<double>(m.V.rows())});
  if (report_non_finite(r, o, m.V)) return r;  // volumes and shapes of NaN tets mean nothing
  for (int t = 0; t < m.T.rows(); ++t) {
    const Vec3 a = row3(m.V, m.T(t, 0)), b = row3(m.V, m.T(t, 1)), c = row3(m.V, m.T(t, 2)),
               d = row3(m.V, m.T(t, 3));
    const std::vector<int> vs{m.T(t, 0), m.T(t, 1), m.T(t, 2), m.T(t, 3)};
    const Vec3 centroid = (a + b + c + d) / 4;
    const double vol = signed_volume(a, b, c, d);
    if (vol < 0) {
      add(r, o, {"inverted_tet", vs, {}, {t}, {centroid}, vol});
      continue;
    }
    const double rr = radius_ratio(a, b, c, d);
    if (rr < o.sliver_ratio) add(r, o, {"sliver_tet", vs, {}, {t}, {centroid}, rr});
  }
  // A tet given twice (the same four nodes) counts its mass and stiffness twice (a duplicated
  // .ele line made a FEM body 3.6x softer in a press, review 2026-12-07), and a node no tet
  // uses has neither: said, as check_tet_connectivity refuses them for the models.
  {
    const TetConnectivity c = tet_connectivity(m.T, m.V.rows());
    for (auto [t0, t] : c.duplicate_tet) {
      std::array<int, 4> key{m.T(t, 0), m.T(t, 1), m.T(t, 2), m.T(t, 3)};
      std::sort(key.begin(), key.end());
      add(r, o, {"duplicate_tet", {key.begin(), key.end()}, {}, {t0, t}, {}, 0.0});
    }
    for (int v : c.unused_vertex) add(r, o, {"unused_vertex", {v}, {}, {}, {row3(m.V, v)}, 0.0});
  }
  for (auto [i, j] : duplicate_vertex_pairs(m.V, o.duplicate_tolerance))
    add(r, o,
        {"duplicate_vertex",
         {i, j},
         {},
         {},
         {row3(m.V, i), row3(m.V, j)},
         (m.V.row(i) - m.V.row(j)).norm()});
  // The boundary of a valid tet mesh is a closed 2-manifold; report where it is not.
  const BoundaryFaces b = boundary_faces(m);
  const SurfaceMesh s = make_surface_mesh(m.V, b.F);
  CheckOptions so = o;
  so.self_intersections = false;
  so.duplicate_tolerance = -1;  // already checked on the tet mesh
  CheckReport sr = check_surface(s, so);
  for (auto& d : sr.defects) {
    if (d.kind == "degenerate_face" || d.kind == "duplicate_vertex") continue;  // tets report those
    if (d.kind == "inside_out") continue;  // the tets' own orientation is inverted_tet
    for (int& f : d.faces) {
      d.tets.push_back(b.tet[f]);
    }
    d.faces.clear();
    add(r, o, d);
  }
  return r;
}

}  // namespace palplab::mesh
