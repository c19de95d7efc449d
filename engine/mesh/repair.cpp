#include "engine/mesh/repair.hpp"

#include <algorithm>
#include <array>
#include <numeric>
#include <set>

#include "common/input_error.hpp"
#include "engine/mesh/check.hpp"
#include "engine/mesh/union_find.hpp"

namespace palplab::mesh {

std::vector<std::string> RepairLog::lines() const {
  std::vector<std::string> s;
  auto add = [&](int n, const char* what) {
    if (n) s.push_back(std::to_string(n) + " " + what);
  };
  add(merged_vertices, "duplicate vertices merged");
  add(dropped_degenerate_faces, "degenerate faces dropped");
  add(dropped_duplicate_faces, "duplicate faces dropped");
  add(flipped_faces, "faces flipped to a consistent orientation");
  if (filled_holes)
    s.push_back(std::to_string(filled_holes) + " holes filled (" + std::to_string(added_faces) +
                " faces, " + std::to_string(added_vertices) + " vertices added)");
  add(removed_unused_vertices, "unused vertices removed");
  add(unfilled_holes, "boundary loops left open (longer than the hole limit)");
  if (s.empty()) s.push_back("no changes");
  return s;
}

SurfaceMesh repair(const SurfaceMesh& in, const RepairOptions& opt, RepairLog* out_log) {
  RepairLog log;
  const int nv = static_cast<int>(in.V.rows());
  for (int i = 0; i < nv; ++i)
    if (!in.V.row(i).allFinite())
      throw InputError("cannot repair: vertex " + std::to_string(i) +
                       " has a coordinate that is not a finite number (NaN or inf); no safe "
                       "automatic fix (`palplab mesh check` lists every such vertex)");
  Positions V = in.V;
  // 1. Merge duplicates: every vertex maps to the smallest index of its duplicate group.
  std::vector<int> rep(nv);
  std::iota(rep.begin(), rep.end(), 0);
  for (auto [i, j] : duplicate_vertex_pairs(V, opt.merge_tolerance)) {
    const int a = detail::find_root(rep, i), b = detail::find_root(rep, j);
    if (a != b) rep[std::max(a, b)] = std::min(a, b);
  }
  for (int v = 0; v < nv; ++v)
    if (detail::find_root(rep, v) != v) ++log.merged_vertices;
  // 2. Faces through the map; drop degenerate and duplicate ones (same vertex set).
  std::vector<std::array<int, 3>> F;
  std::vector<int> region;
  std::set<std::array<int, 3>> seen;
  for (int f = 0; f < in.F.rows(); ++f) {
    std::array<int, 3> t = {detail::find_root(rep, in.F(f, 0)), detail::find_root(rep, in.F(f, 1)),
                            detail::find_root(rep, in.F(f, 2))};
    // The same scale-free test as check's (at 1e300 every face of a clean mesh was dropped and an
    // empty mesh written, exit 0: review 2026-12-06, seventh).
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] ||
        triangle_flatness(row3(V, t[0]), row3(V, t[1]), row3(V, t[2])) <= opt.degenerate_ratio) {
      ++log.dropped_degenerate_faces;
      continue;
    }
    std::array<int, 3> key = t;
    std::sort(key.begin(), key.end());
    if (!seen.insert(key).second) {
      ++log.dropped_duplicate_faces;
      continue;
    }
    F.push_back(t);
    region.push_back(in.regions.empty() ? -1 : in.regions.id[f]);
  }
  auto build = [&]() {
    Faces Fm(static_cast<int>(F.size()), 3);
    for (size_t f = 0; f < F.size(); ++f) Fm.row(f) << F[f][0], F[f][1], F[f][2];
    Regions r;
    if (!in.regions.empty()) {
      r.names = in.regions.names;
      r.id = Eigen::Map<Eigen::VectorXi>(region.data(), static_cast<int>(region.size()));
    }
    return make_surface_mesh(V, Fm, r);
  };
  SurfaceMesh m = build();
  // Whether each input face (after merging) ends up reversed (counted at the end).
  std::vector<char> reversed(F.size(), 0);
  // Closed parts point outwards: an inside-out part (not a cavity's shell, which points into
  // the cavity by right: check.hpp) is reversed whole.
  auto point_outwards = [&]() {
    const auto parts = inside_out_parts(m);
    for (const SurfacePart& p : parts)
      for (int f : p.faces) {
        std::swap(F[f][1], F[f][2]);
        if (static_cast<std::size_t>(f) < reversed.size()) reversed[f] ^= 1;
      }
    if (!parts.empty()) m = build();
  };
  // 3. Orientation: breadth-first over edges with exactly two faces; a neighbour traversing the
  // shared edge in the same direction gets flipped. Non-orientable parts keep their first choice.
  {
    const int nf = static_cast<int>(F.size());
    std::vector<std::vector<int>> by_edge(m.E.rows());
    for (int h = 0; h < 3 * nf; ++h) by_edge[m.he_edge[h]].push_back(h);
    std::vector<int> flip(nf, -1), queue;
    for (int s = 0; s < nf; ++s) {
      if (flip[s] >= 0) continue;
      flip[s] = 0;
      queue.assign(1, s);
      for (size_t q = 0; q < queue.size(); ++q) {
        const int f = queue[q];
        for (int k = 0; k < 3; ++k) {
          const auto& hs = by_edge[m.he_edge[3 * f + k]];
          if (hs.size() != 2) continue;
          const int h = hs[0] / 3 == f ? hs[0] : hs[1], o = hs[0] / 3 == f ? hs[1] : hs[0];
          const int g = o / 3;
          if (g == f || flip[g] >= 0) continue;
          const bool same_dir = he_origin(m, h) == he_origin(m, o);
          flip[g] = flip[f] ^ (same_dir ? 1 : 0);
          queue.push_back(g);
        }
      }
    }
    for (int f = 0; f < nf; ++f)
      if (flip[f]) {
        std::swap(F[f][1], F[f][2]);
        reversed[f] = 1;
      }
    m = build();
    point_outwards();
  }
  // 4. Holes: each boundary loop of at most max_hole_edges edges gets a centre vertex and a fan.
  if (opt.fill_holes) {
    // Region of some face at each vertex, so that a hole's new faces take a bordering region.
    std::vector<int> vregion(V.rows(), -1);
    for (size_t f = 0; f < F.size(); ++f)
      for (int v : F[f])
        if (vregion[v] < 0) vregion[v] = region[f];
    for (const auto& loop : boundary_loops(m)) {
      if (static_cast<int>(loop.size()) > opt.max_hole_edges || loop.size() < 3) {
        ++log.unfilled_holes;
        continue;
      }
      Vec3 c = Vec3::Zero();
      for (int v : loop) c += row3(V, v);
      c /= static_cast<double>(loop.size());
      const int cv = static_cast<int>(V.rows());
      V.conservativeResize(cv + 1, 3);
      V.row(cv) = c.transpose();
      // The loop runs along boundary half-edges a->b (face on their left); the fan must run
      // b->a to pair with them.
      for (size_t i = 0; i < loop.size(); ++i) {
        const int a = loop[i], b = loop[(i + 1) % loop.size()];
        F.push_back({b, a, cv});
        region.push_back(vregion[loop[0]]);
      }
      ++log.filled_holes;
      ++log.added_vertices;
      log.added_faces += static_cast<int>(loop.size());
    }
  }
  // A part that a filled hole closed points outwards too (it was left inside out when the
  // orientation before the filling followed its first face: review 2026-12-06, seventh).
  if (log.filled_holes > 0) {
    m = build();
    point_outwards();
  }
  for (char r : reversed) log.flipped_faces += r;
  // 5. Drop vertices no face uses (merged duplicates, isolated points), keeping the order.
  std::vector<int> remap(V.rows(), -1);
  for (auto& t : F)
    for (int v : t) remap[v] = 0;
  int next = 0;
  for (int v = 0; v < V.rows(); ++v)
    if (remap[v] == 0) remap[v] = next++;
  log.removed_unused_vertices = static_cast<int>(V.rows()) - next - log.merged_vertices;
  if (log.removed_unused_vertices < 0) log.removed_unused_vertices = 0;
  Positions W(next, 3);
  for (int v = 0; v < V.rows(); ++v)
    if (remap[v] >= 0) W.row(remap[v]) = V.row(v);
  for (auto& t : F)
    for (int& v : t) v = remap[v];
  V = std::move(W);
  m = build();
  if (out_log) *out_log = log;
  return m;
}

}  // namespace palplab::mesh
