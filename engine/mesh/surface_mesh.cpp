#include "engine/mesh/surface_mesh.hpp"

#include <algorithm>
#include <array>
#include <numeric>
#include <string>
#include <tuple>

#include "common/input_error.hpp"
#include "engine/mesh/union_find.hpp"

namespace palplab::mesh {

SurfaceMesh make_surface_mesh(Positions V, Faces F, Regions regions) {
  SurfaceMesh m;
  m.V = std::move(V);
  m.F = std::move(F);
  m.regions = std::move(regions);
  for (int f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (m.F(f, k) < 0 || m.F(f, k) >= m.V.rows())
        throw InputError("face " + std::to_string(f) + " refers to vertex " +
                         std::to_string(m.F(f, k)) + " but the mesh has " +
                         std::to_string(m.V.rows()) + " vertices");
  if (!m.regions.empty() && m.regions.id.size() != m.F.rows())
    throw InputError("region table has " + std::to_string(m.regions.id.size()) + " entries for " +
                     std::to_string(m.F.rows()) + " faces");
  for (int f = 0; f < m.regions.id.size(); ++f)
    if (m.regions.id[f] < -1 || m.regions.id[f] >= static_cast<int>(m.regions.names.size()))
      throw InputError("face " + std::to_string(f) + " has region id " +
                       std::to_string(m.regions.id[f]) + " but the mesh names " +
                       std::to_string(m.regions.names.size()) + " regions (ids -1 .. n-1)");
  build_connectivity(m);
  return m;
}

void build_connectivity(SurfaceMesh& m) {
  const int nf = static_cast<int>(m.F.rows());
  const int nv = static_cast<int>(m.V.rows());
  const int nh = 3 * nf;
  // Sort half-edges by their undirected key; equal keys are the faces sharing an edge.
  std::vector<std::tuple<int, int, int>> keys(nh);
  for (int h = 0; h < nh; ++h) {
    int a = he_origin(m, h), b = he_target(m, h);
    keys[h] = {std::min(a, b), std::max(a, b), h};
  }
  std::sort(keys.begin(), keys.end());
  m.twin = Eigen::VectorXi::Constant(nh, -1);
  m.he_edge.resize(nh);
  m.non_manifold_edges.clear();
  m.inconsistent_edges.clear();
  std::vector<std::array<int, 2>> edges;
  std::vector<int> counts;
  for (int i = 0; i < nh;) {
    int j = i;
    while (j < nh && std::get<0>(keys[j]) == std::get<0>(keys[i]) &&
           std::get<1>(keys[j]) == std::get<1>(keys[i]))
      ++j;
    const int e = static_cast<int>(edges.size());
    edges.push_back({std::get<0>(keys[i]), std::get<1>(keys[i])});
    counts.push_back(j - i);
    for (int k = i; k < j; ++k) m.he_edge[std::get<2>(keys[k])] = e;
    if (j - i == 2) {
      int h0 = std::get<2>(keys[i]), h1 = std::get<2>(keys[i + 1]);
      if (he_origin(m, h0) == he_target(m, h1)) {
        m.twin[h0] = h1;
        m.twin[h1] = h0;
      } else {
        m.inconsistent_edges.push_back(e);
      }
    } else if (j - i > 2) {
      m.non_manifold_edges.push_back(e);
    }
    i = j;
  }
  m.E.resize(static_cast<int>(edges.size()), 2);
  m.edge_faces.resize(static_cast<int>(edges.size()));
  for (size_t e = 0; e < edges.size(); ++e) {
    m.E(e, 0) = edges[e][0];
    m.E(e, 1) = edges[e][1];
    m.edge_faces[e] = counts[e];
  }
  // Outgoing half-edge per vertex: prefer one without twin, so that the forward rotation
  // h -> twin(prev(h)) starting from it sweeps the whole fan of a boundary vertex.
  m.vertex_he = Eigen::VectorXi::Constant(nv, -1);
  std::vector<int> nfaces(nv, 0), nfree(nv, 0);
  for (int h = 0; h < nh; ++h) {
    int v = he_origin(m, h);
    ++nfaces[v];
    if (m.twin[h] < 0) {
      ++nfree[v];
      m.vertex_he[v] = h;
    } else if (m.vertex_he[v] < 0) {
      m.vertex_he[v] = h;
    }
  }
  // A vertex is manifold when its faces form one fan: faces are linked through the edges at the
  // vertex that have exactly two faces (orientation does not matter here: that is a separate
  // defect). Local union-find over the faces of each vertex.
  m.non_manifold_vertices.clear();
  std::vector<int> off(nv + 1, 0);
  for (int h = 0; h < nh; ++h) ++off[he_origin(m, h) + 1];
  for (int v = 0; v < nv; ++v) off[v + 1] += off[v];
  std::vector<int> vh(nh), fill(off.begin(), off.end() - 1);
  for (int h = 0; h < nh; ++h) vh[fill[he_origin(m, h)]++] = h;  // outgoing half-edges of v
  std::vector<int> parent;
  for (int v = 0; v < nv; ++v) {
    const int n = off[v + 1] - off[v];
    if (n <= 1) continue;
    parent.resize(n);
    std::iota(parent.begin(), parent.end(), 0);
    auto root = [&](int x) {
      while (parent[x] != x) x = parent[x] = parent[parent[x]];
      return x;
    };
    // Face i (outgoing h_i = v->a_i, incoming prev(h_i) = b_i->v) touches edges {v,a_i}, {v,b_i}.
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) {
        const int hi = vh[off[v] + i], hj = vh[off[v] + j];
        const int ei[2] = {m.he_edge[hi], m.he_edge[he_prev(hi)]};
        const int ej[2] = {m.he_edge[hj], m.he_edge[he_prev(hj)]};
        for (int x : ei)
          for (int y : ej)
            if (x == y && m.edge_faces[x] == 2) parent[root(i)] = root(j);
      }
    int comps = 0;
    for (int i = 0; i < n; ++i) comps += root(i) == i;
    if (comps > 1) m.non_manifold_vertices.push_back(v);
  }
}

void one_ring(const SurfaceMesh& m, int v, std::vector<int>& out) {
  out.clear();
  const int start = m.vertex_he[v];
  if (start < 0) return;
  int h = start;
  const int limit = 3 * static_cast<int>(m.F.rows());
  while (static_cast<int>(out.size()) <= limit) {
    out.push_back(he_target(m, h));
    int p = he_prev(h);
    int t = m.twin[p];
    if (t < 0) {  // reached the other side of a boundary fan: the last neighbour closes it
      out.push_back(he_origin(m, p));
      return;
    }
    h = t;
    if (h == start) return;
  }
}

void vertex_faces(const SurfaceMesh& m, int v, std::vector<int>& out) {
  out.clear();
  const int start = m.vertex_he[v];
  if (start < 0) return;
  int h = start;
  const int limit = static_cast<int>(m.F.rows());
  while (static_cast<int>(out.size()) <= limit) {
    out.push_back(he_face(h));
    int t = m.twin[he_prev(h)];
    if (t < 0 || t == start) return;
    h = t;
  }
}

bool is_boundary_vertex(const SurfaceMesh& m, int v) {
  int h = m.vertex_he[v];
  return h >= 0 && m.edge_faces[m.he_edge[h]] == 1;
}

int count_boundary_edges(const SurfaceMesh& m) {
  return static_cast<int>((m.edge_faces.array() == 1).count());
}

std::vector<std::vector<int>> boundary_loops(const SurfaceMesh& m) {
  const int nh = static_cast<int>(m.twin.size());
  // Outgoing boundary half-edge of each vertex (one for manifold boundary vertices).
  std::vector<int> out(m.V.rows(), -1);
  std::vector<int> bhe;
  for (int h = 0; h < nh; ++h)
    if (m.edge_faces[m.he_edge[h]] == 1) {
      bhe.push_back(h);
      if (out[he_origin(m, h)] < 0) out[he_origin(m, h)] = h;
    }
  std::vector<char> used(nh, 0);
  std::vector<std::vector<int>> loops;
  for (int h0 : bhe) {
    if (used[h0]) continue;
    std::vector<int> loop;
    int h = h0;
    while (h >= 0 && !used[h]) {
      used[h] = 1;
      loop.push_back(he_origin(m, h));
      h = out[he_target(m, h)];
    }
    loops.push_back(std::move(loop));
  }
  return loops;
}

int count_used_vertices(const SurfaceMesh& m) {
  std::vector<char> used(m.V.rows(), 0);
  for (int i = 0; i < m.F.size(); ++i) used[m.F.data()[i]] = 1;
  return static_cast<int>(std::count(used.begin(), used.end(), 1));
}

int euler_characteristic(const SurfaceMesh& m) {
  return count_used_vertices(m) - static_cast<int>(m.E.rows()) + static_cast<int>(m.F.rows());
}

int face_components(const SurfaceMesh& m, Eigen::VectorXi* comp) {
  const int nv = static_cast<int>(m.V.rows());
  std::vector<int> p(nv);
  std::iota(p.begin(), p.end(), 0);
  for (int f = 0; f < m.F.rows(); ++f)
    for (int k = 1; k < 3; ++k)
      p[detail::find_root(p, m.F(f, k))] = detail::find_root(p, m.F(f, 0));
  std::vector<int> id(nv, -1);
  int n = 0;
  if (comp) comp->resize(m.F.rows());
  for (int f = 0; f < m.F.rows(); ++f) {
    int r = detail::find_root(p, m.F(f, 0));
    if (id[r] < 0) id[r] = n++;
    if (comp) (*comp)[f] = id[r];
  }
  return n;
}

bool is_orientable(const SurfaceMesh& m) {
  // Two-colour the faces: across an edge with two faces, "same direction" means one of them
  // must be flipped. A contradiction means no consistent orientation exists (Moebius strip).
  const int nf = static_cast<int>(m.F.rows());
  std::vector<std::vector<std::pair<int, int>>> adj(nf);  // (neighbour, flip needed)
  std::vector<std::vector<int>> by_edge(m.E.rows());
  for (int h = 0; h < 3 * nf; ++h) by_edge[m.he_edge[h]].push_back(h);
  for (auto& hs : by_edge) {
    if (hs.size() != 2) continue;
    int a = hs[0], b = hs[1];
    int flip = he_origin(m, a) == he_origin(m, b) ? 1 : 0;
    adj[a / 3].push_back({b / 3, flip});
    adj[b / 3].push_back({a / 3, flip});
  }
  std::vector<int> side(nf, -1), stack;
  for (int s = 0; s < nf; ++s) {
    if (side[s] >= 0) continue;
    side[s] = 0;
    stack.push_back(s);
    while (!stack.empty()) {
      int f = stack.back();
      stack.pop_back();
      for (auto [g, flip] : adj[f]) {
        int want = side[f] ^ flip;
        if (side[g] < 0) {
          side[g] = want;
          stack.push_back(g);
        } else if (side[g] != want) {
          return false;
        }
      }
    }
  }
  return true;
}

bool is_closed_manifold(const SurfaceMesh& m) {
  return m.F.rows() > 0 && count_boundary_edges(m) == 0 && m.non_manifold_edges.empty() &&
         m.non_manifold_vertices.empty() && m.inconsistent_edges.empty() && is_orientable(m);
}

int genus(const SurfaceMesh& m) {
  if (m.F.rows() == 0 || count_boundary_edges(m) != 0 || !m.non_manifold_edges.empty() ||
      !m.non_manifold_vertices.empty() || !is_orientable(m))
    return -1;
  const int chi = euler_characteristic(m);
  const int c = face_components(m);
  return (2 * c - chi) / 2;
}

Positions face_normals(const Positions& V, const Faces& F) {
  Positions N(F.rows(), 3);
  for (int f = 0; f < F.rows(); ++f) {
    Vec3 a = row3(V, F(f, 0)), b = row3(V, F(f, 1)), c = row3(V, F(f, 2));
    Vec3 n = (b - a).cross(c - a);
    double l = n.norm();
    N.row(f) = (l > 0 ? Vec3(n / l) : Vec3::Zero()).transpose();
  }
  return N;
}

Eigen::VectorXd face_areas(const Positions& V, const Faces& F) {
  Eigen::VectorXd A(F.rows());
  for (int f = 0; f < F.rows(); ++f) {
    Vec3 a = row3(V, F(f, 0)), b = row3(V, F(f, 1)), c = row3(V, F(f, 2));
    A[f] = 0.5 * (b - a).cross(c - a).norm();
  }
  return A;
}

Positions vertex_normals(const Positions& V, const Faces& F) {
  Positions N = Positions::Zero(V.rows(), 3);
  for (int f = 0; f < F.rows(); ++f) {
    Vec3 a = row3(V, F(f, 0)), b = row3(V, F(f, 1)), c = row3(V, F(f, 2));
    // The unnormalised cross product is twice the area times the unit normal: area weights.
    Eigen::RowVector3d n = (b - a).cross(c - a).transpose();
    for (int k = 0; k < 3; ++k) N.row(F(f, k)) += n;
  }
  for (int v = 0; v < V.rows(); ++v) {
    double l = N.row(v).norm();
    if (l > 0) N.row(v) /= l;
  }
  return N;
}

double enclosed_volume(const Positions& V, const Faces& F) {
  if (V.rows() == 0) return 0;
  // Origin at the centre of the bounding box: the sum of signed cone volumes is exact for a
  // closed surface wherever the apex is, and a nearby apex keeps the rounding error small.
  const Vec3 o = 0.5 * (V.colwise().minCoeff() + V.colwise().maxCoeff()).transpose();
  double vol = 0;
  for (int f = 0; f < F.rows(); ++f) {
    Vec3 a = row3(V, F(f, 0)) - o, b = row3(V, F(f, 1)) - o, c = row3(V, F(f, 2)) - o;
    vol += a.dot(b.cross(c));
  }
  return vol / 6.0;
}

Eigen::VectorXi vertex_regions(const SurfaceMesh& m) {
  if (m.regions.empty()) return {};
  Eigen::VectorXi r = Eigen::VectorXi::Constant(m.V.rows(), -1);
  for (int f = 0; f < m.F.rows(); ++f) {
    int id = m.regions.id[f];
    if (id < 0) continue;
    for (int k = 0; k < 3; ++k) {
      int& x = r[m.F(f, k)];
      if (x < 0 || id < x) x = id;
    }
  }
  return r;
}

}  // namespace palplab::mesh
