#include "engine/mesh/tet_mesh.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>

#include "common/input_error.hpp"

namespace palplab::mesh {

double signed_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return (b - a).dot((c - a).cross(d - a)) / 6.0;
}

double signed_volume(const Positions& V, const Tets& T, int t) {
  return signed_volume(row3(V, T(t, 0)), row3(V, T(t, 1)), row3(V, T(t, 2)), row3(V, T(t, 3)));
}

double radius_ratio(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const double vol = std::abs(signed_volume(a, b, c, d));
  if (vol <= 0) return 0;
  // Inradius = 3V / total face area.
  const double area = 0.5 * ((b - a).cross(c - a).norm() + (b - a).cross(d - a).norm() +
                             (c - a).cross(d - a).norm() + (c - b).cross(d - b).norm());
  const double r_in = 3 * vol / area;
  // Circumradius: |u²(v×w) + v²(w×u) + w²(u×v)| / (12 V) with u,v,w the edges from a.
  const Vec3 u = b - a, v = c - a, w = d - a;
  const Vec3 num =
      u.squaredNorm() * v.cross(w) + v.squaredNorm() * w.cross(u) + w.squaredNorm() * u.cross(v);
  const double r_circ = num.norm() / (12 * vol);
  return std::clamp(3 * r_in / r_circ, 0.0, 1.0);
}

TetMesh make_tet_mesh(Positions V, Tets T, Eigen::VectorXi attribute, Regions regions) {
  TetMesh m;
  m.V = std::move(V);
  m.T = std::move(T);
  const int nv = static_cast<int>(m.V.rows()), nt = static_cast<int>(m.T.rows());
  for (int t = 0; t < nt; ++t)
    for (int k = 0; k < 4; ++k)
      if (m.T(t, k) < 0 || m.T(t, k) >= nv)
        throw InputError("tet " + std::to_string(t) + " refers to vertex " +
                         std::to_string(m.T(t, k)) + " but the mesh has " + std::to_string(nv) +
                         " vertices");
  if (attribute.size() == 0) attribute = Eigen::VectorXi::Zero(nt);
  if (attribute.size() != nt)
    throw InputError("attribute table has " + std::to_string(attribute.size()) + " entries for " +
                     std::to_string(nt) + " tets");
  if (!regions.empty() && regions.id.size() != nt)
    throw InputError("region table has " + std::to_string(regions.id.size()) + " entries for " +
                     std::to_string(nt) + " tets");
  for (int t = 0; t < regions.id.size(); ++t)
    if (regions.id[t] < -1 || regions.id[t] >= static_cast<int>(regions.names.size()))
      throw InputError("tet " + std::to_string(t) + " has region id " +
                       std::to_string(regions.id[t]) + " but the mesh names " +
                       std::to_string(regions.names.size()) + " regions (ids -1 .. n-1)");
  m.attribute = std::move(attribute);
  m.regions = std::move(regions);
  m.volume.resize(nt);
  for (int t = 0; t < nt; ++t) {
    // V = |(d − a)·((d − b) × (d − c))| / 6.
    Vec3 a = row3(m.V, m.T(t, 0)), b = row3(m.V, m.T(t, 1)), c = row3(m.V, m.T(t, 2)),
         d = row3(m.V, m.T(t, 3));
    m.volume[t] = std::abs((d - a).dot((d - b).cross(d - c))) / 6.0;
  }
  auto& vt = m.vertex_tets;
  vt.offset.assign(nv + 1, 0);
  for (int i = 0; i < m.T.size(); ++i) ++vt.offset[m.T.data()[i] + 1];
  for (int v = 0; v < nv; ++v) vt.offset[v + 1] += vt.offset[v];
  vt.index.resize(vt.offset[nv]);
  std::vector<int> fill(vt.offset.begin(), vt.offset.end() - 1);
  for (int t = 0; t < nt; ++t)  // t ascending, so each row comes out sorted
    for (int k = 0; k < 4; ++k) vt.index[fill[m.T(t, k)]++] = t;
  return m;
}

namespace {

bool tet_has(const Tets& T, int t, int v) {
  return T(t, 0) == v || T(t, 1) == v || T(t, 2) == v || T(t, 3) == v;
}

// Local index of the face of tet s made of vertices {a,b,c}, or -1.
int face_in(const Tets& T, int s, int a, int b, int c) {
  if (!tet_has(T, s, a) || !tet_has(T, s, b) || !tet_has(T, s, c)) return -1;
  for (int k = 0; k < 4; ++k)
    if (T(s, k) != a && T(s, k) != b && T(s, k) != c) return k;
  return -1;
}

// Decides whether face (t, k) with neighbour s (-1 if none) is output.
bool keep_face(const TetMesh& m, int t, int s, const BoundaryOptions& o) {
  const int at = m.attribute[t];
  if (s < 0) return !(o.skip_rigid_outer && o.rigid && o.rigid(at));
  const int as = m.attribute[s];
  if (!o.tissue_interfaces || as == at) return false;
  if (o.skip_towards_rigid && o.rigid && o.rigid(as)) return false;
  if (o.skip_towards_rigid && o.rigid && o.rigid(at)) return false;
  // Output an interface once: from the tet with the smaller attribute.
  return at < as;
}

void push(BoundaryFaces& b, std::vector<std::array<int, 5>>& out, const Tets& T, int t, int k) {
  out.push_back({T(t, kTetFace[k][0]), T(t, kTetFace[k][1]), T(t, kTetFace[k][2]), t, k});
}

BoundaryFaces pack(std::vector<std::array<int, 5>>& out) {
  BoundaryFaces b;
  b.F.resize(static_cast<int>(out.size()), 3);
  b.tet.resize(static_cast<int>(out.size()));
  b.local.resize(static_cast<int>(out.size()));
  for (size_t i = 0; i < out.size(); ++i) {
    b.F.row(i) << out[i][0], out[i][1], out[i][2];
    b.tet[i] = out[i][3];
    b.local[i] = out[i][4];
  }
  return b;
}

}  // namespace

TetConnectivity tet_connectivity(const Tets& T, long n_vertices) {
  TetConnectivity c;
  std::map<std::array<int, 4>, int> first;
  std::vector<char> used(static_cast<std::size_t>(std::max(0L, n_vertices)), 0);
  for (int t = 0; t < T.rows(); ++t) {
    std::array<int, 4> key{T(t, 0), T(t, 1), T(t, 2), T(t, 3)};
    for (int v : key)
      if (v >= 0 && v < n_vertices) used[static_cast<std::size_t>(v)] = 1;
    std::sort(key.begin(), key.end());
    if (std::adjacent_find(key.begin(), key.end()) != key.end()) c.repeated_node.push_back(t);
    if (const auto [it, fresh] = first.emplace(key, t); !fresh)
      c.duplicate_tet.emplace_back(it->second, t);
  }
  for (long v = 0; v < n_vertices; ++v)
    if (!used[static_cast<std::size_t>(v)]) c.unused_vertex.push_back(static_cast<int>(v));
  return c;
}

Tets tet_neighbours(const TetMesh& m) {
  const Tets& T = m.T;
  Tets N = Tets::Constant(T.rows(), 4, -1);
  for (int t = 0; t < T.rows(); ++t)
    for (int k = 0; k < 4; ++k) {
      if (N(t, k) >= 0) continue;
      int a = T(t, kTetFace[k][0]), b = T(t, kTetFace[k][1]), c = T(t, kTetFace[k][2]);
      int lo = std::min({a, b, c});
      for (int s : m.vertex_tets.row(lo)) {
        if (s == t) continue;
        int j = face_in(T, s, a, b, c);
        if (j >= 0) {
          N(t, k) = s;
          N(s, j) = t;
          break;
        }
      }
    }
  return N;
}

BoundaryFaces boundary_faces(const TetMesh& m, const BoundaryOptions& opt) {
  BoundaryFaces b;
  std::vector<std::array<int, 5>> out;
  const Tets N = tet_neighbours(m);
  for (int t = 0; t < m.T.rows(); ++t)
    for (int k = 0; k < 4; ++k)
      if (keep_face(m, t, N(t, k), opt)) push(b, out, m.T, t, k);
  return pack(out);
}

BoundaryFaces boundary_faces_brute_force(const TetMesh& m, const BoundaryOptions& opt) {
  BoundaryFaces b;
  std::vector<std::array<int, 5>> out;
  const Tets& T = m.T;
  for (int t = 0; t < T.rows(); ++t)
    for (int k = 0; k < 4; ++k) {
      int a = T(t, kTetFace[k][0]), bb = T(t, kTetFace[k][1]), c = T(t, kTetFace[k][2]);
      int nb = -1;
      for (int s = 0; s < T.rows() && nb < 0; ++s)
        if (s != t && face_in(T, s, a, bb, c) >= 0) nb = s;
      if (keep_face(m, t, nb, opt)) push(b, out, T, t, k);
    }
  return pack(out);
}

Eigen::VectorXi vertex_regions(const TetMesh& m) {
  if (m.regions.empty()) return {};
  Eigen::VectorXi r = Eigen::VectorXi::Constant(m.V.rows(), -1);
  for (int t = 0; t < m.T.rows(); ++t) {
    int id = m.regions.id[t];
    if (id < 0) continue;
    for (int k = 0; k < 4; ++k) {
      int& x = r[m.T(t, k)];
      if (x < 0 || id < x) x = id;
    }
  }
  return r;
}

}  // namespace palplab::mesh
