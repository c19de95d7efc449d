#include "engine/models/refinement.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace palplab::engine {

namespace {

inline std::uint64_t edge_key(int a, int b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) |
         static_cast<std::uint32_t>(b);
}

int find_mid(const AdaptiveMassSpring& m, int a, int b) {
  // Cheap reject: both ends of a split edge are flagged (most edges are far from any split).
  const int n = static_cast<int>(m.mid_flag.size());
  if (a >= n || b >= n || !m.mid_flag[a] || !m.mid_flag[b]) return -1;
  auto it = m.midpoint.find(edge_key(a, b));
  return it == m.midpoint.end() ? -1 : it->second;
}

// Rest positions of all nodes (coarse rest + midpoints of rest).
Eigen::Vector3d rest_pos(const AdaptiveMassSpring& m, int i) {
  return m.sys.X_rest.row(i).transpose();
}

double rest_area(const AdaptiveMassSpring& m, const RefineTri& t) {
  const Eigen::Vector3d a = rest_pos(m, t.v[0]), b = rest_pos(m, t.v[1]), c = rest_pos(m, t.v[2]);
  return 0.5 * (b - a).cross(c - a).norm();
}

// Creates (or finds) the midpoint node of edge (a, b); appends a row to the current system
// (state = mean of the parents), so rest positions of new nodes are available immediately.
int get_mid(AdaptiveMassSpring& m, int a, int b, int level, int root) {
  const std::uint64_t k = edge_key(a, b);
  auto it = m.midpoint.find(k);
  if (it != m.midpoint.end()) return it->second;
  MassSpringSystem& s = m.sys;
  const int id = static_cast<int>(s.X.rows());
  auto grow = [&](RowMatX3d& M) {
    M.conservativeResize(id + 1, 3);
    M.row(id) = 0.5 * (M.row(a) + M.row(b));
  };
  grow(s.X);
  grow(s.V);
  grow(s.X_rest);
  s.F_ext.conservativeResize(id + 1, 3);
  s.F_ext.row(id).setZero();
  m.midpoint.emplace(k, id);
  if (m.mid_flag.size() < static_cast<size_t>(id + 1)) m.mid_flag.resize(id + 1, 0);
  for (int e : {a, b})
    if (!m.mid_flag[e]) {
      m.mid_flag[e] = 1;
      m.flagged.push_back(e);
    }
  m.midpoint_parents.push_back({std::min(a, b), std::max(a, b)});
  m.midpoint_root.push_back(root);
  m.node_level.push_back(level);
  return id;
}

void split(AdaptiveMassSpring& m, int t) {
  if (m.tris[t].child >= 0) return;
  const RefineTri T = m.tris[t];
  const int d = T.depth + 1;
  const int m01 = get_mid(m, T.v[0], T.v[1], d, T.root),
            m12 = get_mid(m, T.v[1], T.v[2], d, T.root),
            m20 = get_mid(m, T.v[2], T.v[0], d, T.root);
  const int c = static_cast<int>(m.tris.size());
  m.tris[t].child = c;
  m.tris.push_back({{T.v[0], m01, m20}, -1, d, T.root});
  m.tris.push_back({{m01, T.v[1], m12}, -1, d, T.root});
  m.tris.push_back({{m20, m12, T.v[2]}, -1, d, T.root});
  m.tris.push_back({{m01, m12, m20}, -1, d, T.root});
}

void split_area(AdaptiveMassSpring& m, int t, const RefineParams& p) {
  if (m.tris[t].depth >= p.max_level) return;
  if (m.tris[t].child < 0) {
    if (!(rest_area(m, m.tris[t]) > p.threshold_area)) return;
    split(m, t);
  }
  const int c = m.tris[t].child;
  for (int k = 0; k < 4; ++k) split_area(m, c + k, p);
}

void split_to(AdaptiveMassSpring& m, int t, int level) {
  if (m.tris[t].depth >= level) return;
  split(m, t);
  const int c = m.tris[t].child;
  for (int k = 0; k < 4; ++k) split_to(m, c + k, level);
}

// 1-irregular balance and green closure: split leaves until every leaf has at most two hanging
// midpoints and no neighbour is more than one level finer along a shared edge.
void close_mesh(AdaptiveMassSpring& m) {
  bool changed = true;
  while (changed) {
    changed = false;
    for (size_t t = 0; t < m.tris.size(); ++t) {
      if (m.tris[t].child >= 0) continue;
      int hanging = 0;
      bool too_fine = false;
      for (int k = 0; k < 3; ++k) {
        const int a = m.tris[t].v[k], b = m.tris[t].v[(k + 1) % 3];
        const int mid = find_mid(m, a, b);
        if (mid < 0) continue;
        ++hanging;
        if (find_mid(m, a, mid) >= 0 || find_mid(m, mid, b) >= 0) too_fine = true;
      }
      if (hanging == 3 || too_fine) {
        split(m, static_cast<int>(t));
        changed = true;
      }
    }
  }
}

// Emits the conforming surface and rebuilds masses, springs and home springs (see the header).
void rebuild(AdaptiveMassSpring& m) {
  MassSpringSystem& s = m.sys;
  const MassSpringSystem& c = m.coarse;
  const long N = c.nodes();
  const long n = s.X.rows();

  // --- faces (with the coarse face each comes from and its depth) ---
  std::vector<std::array<int, 3>> faces;
  std::vector<int> face_depth, face_root;
  int max_depth = 0;
  auto emit = [&](int a, int b, int cc, int depth, int root) {
    faces.push_back({a, b, cc});
    face_depth.push_back(depth);
    face_root.push_back(root);
  };
  for (const RefineTri& t : m.tris) {
    if (t.child >= 0) continue;
    max_depth = std::max(max_depth, t.depth);
    int h[3];
    int count = 0;
    for (int k = 0; k < 3; ++k) {
      h[k] = find_mid(m, t.v[k], t.v[(k + 1) % 3]);
      count += h[k] >= 0;
    }
    if (count == 0) {
      emit(t.v[0], t.v[1], t.v[2], t.depth, t.root);
    } else if (count == 1) {
      const int k = h[0] >= 0 ? 0 : (h[1] >= 0 ? 1 : 2);
      const int a = t.v[k], b = t.v[(k + 1) % 3], cc = t.v[(k + 2) % 3];
      emit(a, h[k], cc, t.depth, t.root);
      emit(h[k], b, cc, t.depth, t.root);
    } else {
      // Two hanging midpoints on edges i (v_i v_i+1) and i+1; the edge without one is i+2.
      const int missing = h[0] < 0 ? 0 : (h[1] < 0 ? 1 : 2);
      const int i = (missing + 1) % 3;
      const int a = t.v[i], b = t.v[(i + 1) % 3], cc = t.v[(i + 2) % 3];
      const int mi = h[i], mj = h[(i + 1) % 3];
      emit(mi, b, mj, t.depth, t.root);
      emit(a, mi, mj, t.depth, t.root);
      emit(a, mj, cc, t.depth, t.root);
    }
  }
  m.F.resize(static_cast<long>(faces.size()), 3);
  for (size_t f = 0; f < faces.size(); ++f) m.F.row(f) << faces[f][0], faces[f][1], faces[f][2];
  m.level = max_depth;
  std::vector<double> face_leaf_area(faces.size());
  for (size_t f = 0; f < faces.size(); ++f) {
    const Eigen::Vector3d pa = s.X_rest.row(faces[f][0]).transpose();
    face_leaf_area[f] =
        0.5 * (Eigen::Vector3d(s.X_rest.row(faces[f][1]).transpose()) - pa)
                  .cross(Eigen::Vector3d(s.X_rest.row(faces[f][2]).transpose()) - pa)
                  .norm();
  }

  // --- which roots changed: an unsplit root without hanging midpoints emits itself alone ---
  const long F0n = m.F0.rows();
  std::vector<int> emitted(F0n, 0);
  for (int r : face_root) ++emitted[r];
  std::vector<int> refined_roots;
  for (long r = 0; r < F0n; ++r)
    if (emitted[r] != 1 || m.tris[r].child >= 0) refined_roots.push_back(static_cast<int>(r));
  auto len2 = [&](int a, int b) { return (s.X_rest.row(a) - s.X_rest.row(b)).squaredNorm(); };

  // --- node quantities (mass, support): each coarse node's value is split over its surface
  // faces by area (q_v A_f / A_v); a refined root gathers its corners' shares and lumps them
  // over its leaves by area, so the patch's total (and the model's) is conserved exactly ---
  auto redistribute = [&](const Eigen::VectorXd& coarse_q, Eigen::VectorXd& q) {
    q.setZero(n);
    q.head(N) = coarse_q;
    std::vector<double> gathered(F0n, 0.0);
    for (int r : refined_roots)
      for (int k = 0; k < 3; ++k) {
        const int v = m.F0(r, k);
        if (!(m.node_area[v] > 0.0)) continue;
        const double share = coarse_q[v] * m.face_area[r] / m.node_area[v];
        q[v] -= share;
        gathered[r] += share;
      }
    for (size_t f = 0; f < faces.size(); ++f) {
      const int r = face_root[f];
      if (emitted[r] == 1 && m.tris[r].child < 0) continue;
      const double part = gathered[r] * face_leaf_area[f] / m.face_area[r] / 3.0;
      for (int k = 0; k < 3; ++k) q[faces[f][k]] += part;
    }
  };
  redistribute(c.mass, s.mass);
  redistribute(c.home_ks, s.home_ks);
  redistribute(c.home_kd, s.home_kd);

  // --- springs: a surface face f carries the membrane share c_f A_f / |e|^2 of each of its
  // edges' springs (van Gelder 1998: k_e = sum over the elements at e of E |element| / |e|^2).
  // A refined root hands its share from its coarse edges to its leaves' edges by the same rule,
  // which conserves the strain energy of any uniform in-plane strain exactly for 1->4 splits
  // (children are similar to the parent) and to first order for the green closures. ---
  Eigen::VectorXd ks = c.springs.ks, kd = c.springs.kd;
  std::unordered_map<std::uint64_t, double> added;
  added.reserve(refined_roots.size() * 12);
  for (int r : refined_roots) {
    const double cf = m.face_membrane[r];
    const int apex = m.face_apex[r];
    for (int k = 0; k < 3; ++k) {
      const int a = m.F0(r, k), b = m.F0(r, (k + 1) % 3);
      auto it = m.coarse_spring.find(edge_key(a, b));
      if (it != m.coarse_spring.end()) ks[it->second] -= cf * m.face_area[r] / len2(a, b);
      if (apex < 0) continue;
      it = m.coarse_spring.find(edge_key(a, apex));
      if (it != m.coarse_spring.end()) ks[it->second] -= cf * m.face_area[r] / len2(a, apex);
    }
  }
  for (size_t f = 0; f < faces.size(); ++f) {
    const int r = face_root[f];
    if (emitted[r] == 1 && m.tris[r].child < 0) continue;
    // On a tet model the leaf is the base of a sub-tet of the root's tet (the fan over the
    // apex): E V_sub = c_r A_leaf on each of its six edges, the three to the apex included.
    const double cf = m.face_membrane[r] * face_leaf_area[f];
    const int apex = m.face_apex[r];
    for (int k = 0; k < 3; ++k) {
      const int a = faces[f][k], b = faces[f][(k + 1) % 3];
      added[edge_key(a, b)] += cf / len2(a, b);
      if (apex >= 0) added[edge_key(a, apex)] += cf / len2(a, apex);
    }
  }
  // The other tets at a split surface edge (a tet with no refined boundary face): bisected at
  // the nodes along the edge, each part (p, q, c, d) with E V |pq| / |ab|; a tet with k split
  // edges gives each the share 1/k.
  if (m.tets.rows() > 0) {
    std::unordered_map<int, int> face_fanned;  // tet -> refined boundary faces of it
    for (int r : refined_roots) ++face_fanned[m.face_tet[r]];
    std::vector<int> cand;
    for (int r : refined_roots)
      for (int k = 0; k < 3; ++k) {
        const int a = m.F0(r, k), b = m.F0(r, (k + 1) % 3);
        if (find_mid(m, a, b) < 0) continue;
        for (int t : m.edge_tets.at(edge_key(a, b)))
          if (!face_fanned.count(t)) cand.push_back(t);
      }
    std::sort(cand.begin(), cand.end());
    cand.erase(std::unique(cand.begin(), cand.end()), cand.end());
    std::vector<int> chain;
    for (int t : cand) {
      int v[4], split_edges = 0;
      for (int i = 0; i < 4; ++i) v[i] = m.tets(t, i);
      for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) split_edges += find_mid(m, v[i], v[j]) >= 0;
      const double ev = m.tet_ev[t] / split_edges;
      for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) {
          const int a = v[i], b = v[j];
          if (find_mid(m, a, b) < 0) continue;
          int c = -1, d = -1;
          for (int q = 0; q < 4; ++q)
            if (q != i && q != j) (c < 0 ? c : d) = v[q];
          // The tet's share leaves its six coarse edges ...
          for (int p = 0; p < 4; ++p)
            for (int q = p + 1; q < 4; ++q)
              ks[m.coarse_spring.at(edge_key(v[p], v[q]))] -= ev / len2(v[p], v[q]);
          // ... for its parts between consecutive nodes along (a, b).
          chain.assign({a});
          auto walk = [&](auto&& self, int p, int q) -> void {
            const int mid = find_mid(m, p, q);
            if (mid < 0) {
              chain.push_back(q);
              return;
            }
            self(self, p, mid);
            self(self, mid, q);
          };
          walk(walk, a, b);
          const double ab = std::sqrt(len2(a, b));
          for (size_t s2 = 0; s2 + 1 < chain.size(); ++s2) {
            const int p = chain[s2], q = chain[s2 + 1];
            const double part = ev * std::sqrt(len2(p, q)) / ab;
            for (const auto& [x, y] : {std::pair{p, q}, std::pair{p, c}, std::pair{p, d},
                                       std::pair{q, c}, std::pair{q, d}, std::pair{c, d}})
              added[edge_key(x, y)] += part / len2(x, y);
          }
        }
    }
  }
  std::vector<std::pair<std::uint64_t, double>> fresh;
  for (const auto& [key, val] : added) {
    const int a = static_cast<int>(key >> 32), b = static_cast<int>(key & 0xffffffffu);
    auto it = (a < N && b < N) ? m.coarse_spring.find(key) : m.coarse_spring.end();
    if (it != m.coarse_spring.end())
      ks[it->second] += val;
    else
      fresh.emplace_back(key, val);
  }
  std::sort(fresh.begin(), fresh.end());
  long kept = 0;
  const double eps = 1e-9;  // a share removed to rounding: the spring is gone
  for (long k = 0; k < c.springs.size(); ++k)
    if (ks[k] > eps * c.springs.ks[k]) ++kept;
  const long S = kept + static_cast<long>(fresh.size());
  const long ties = m.tets.rows() > 0 ? 3 * (n - N) : 0;
  Springs sp;
  sp.E.resize(S, 2);
  sp.rest.resize(S);
  sp.ks.resize(S);
  sp.kd.resize(S);
  long w = 0;
  for (long k = 0; k < c.springs.size(); ++k) {
    if (!(ks[k] > eps * c.springs.ks[k])) continue;
    sp.E.row(w) = c.springs.E.row(k);
    sp.rest[w] = c.springs.rest[k];
    sp.ks[w] = ks[k];
    sp.kd[w] = c.springs.ks[k] > 0.0 ? kd[k] * ks[k] / c.springs.ks[k] : kd[k];
    ++w;
  }
  for (const auto& [key, val] : fresh) {
    const int a = static_cast<int>(key >> 32), b = static_cast<int>(key & 0xffffffffu);
    sp.E.row(w) << a, b;
    sp.rest[w] = std::sqrt(len2(a, b));
    sp.ks[w] = val;
    sp.kd[w] = m.beta * val;
    ++w;
  }
  // The dent ties (tet models): (m, a), (m, b) with k/2 and (a, b) with -k/4, rest length 0.
  if (ties > 0) {
    sp.E.conservativeResize(S + ties, 2);
    sp.rest.conservativeResize(S + ties);
    sp.ks.conservativeResize(S + ties);
    sp.kd.conservativeResize(S + ties);
    for (long i = N; i < n; ++i) {
      const int mi = static_cast<int>(i);
      const auto& pr = m.midpoint_parents[i - N];
      const double k = kConeDentStiffness * m.tet_estar[m.face_tet[m.midpoint_root[i - N]]] *
                       std::sqrt(len2(mi, pr[0]));
      const std::array<int, 2> ends[3] = {{mi, pr[0]}, {mi, pr[1]}, {pr[0], pr[1]}};
      const double share[3] = {0.5, 0.5, -0.25};
      for (int t = 0; t < 3; ++t, ++w) {
        sp.E.row(w) << ends[t][0], ends[t][1];
        sp.rest[w] = 0.0;
        sp.ks[w] = share[t] * k;
        sp.kd[w] = 0.0;
      }
    }
  }
  s.springs = std::move(sp);
  m.new_nodes = n - N;
  m.new_springs = static_cast<long>(fresh.size()) + ties;
  build_adjacency(s);

  // --- lumped surface area of the current surface (the contact patch weights) ---
  m.surface_area.setZero(n);
  for (size_t f = 0; f < faces.size(); ++f)
    for (int k = 0; k < 3; ++k) m.surface_area[faces[f][k]] += face_leaf_area[f] / 3.0;
  s.fixed.resize(n, 0);
  for (long i = N; i < n; ++i) {
    const auto& pr = m.midpoint_parents[i - N];
    s.fixed[i] = s.fixed[pr[0]] && s.fixed[pr[1]];
  }
  m.h = m.h_coarse / std::ldexp(1.0, m.level);  // Eq 5.18
}

}  // namespace

void level_and_slod(const AdaptiveMassSpring& m, int root, int* level, int* slod) {
  // Breadth-first over the tree by depth: l = deepest complete level, SLoD from the fraction of
  // level-l triangles split further.
  std::vector<int> cur{root}, next;
  int l = 0;
  while (true) {
    int split_count = 0;
    for (int t : cur)
      if (m.tris[t].child >= 0) ++split_count;
    if (split_count == static_cast<int>(cur.size())) {
      next.clear();
      for (int t : cur)
        for (int k = 0; k < 4; ++k) next.push_back(m.tris[t].child + k);
      cur.swap(next);
      ++l;
      continue;
    }
    *level = l;
    if (split_count == 0) {
      *slod = 4;
    } else {
      const double frac = static_cast<double>(split_count) / cur.size();
      *slod = std::min(3, static_cast<int>(std::ceil(4.0 * frac)));
    }
    return;
  }
}

AdaptiveMassSpring make_adaptive(MassSpringSystem coarse, RowMatX3i F0,
                                 Eigen::VectorXd face_membrane, double beta, double h_coarse,
                                 const CoarseTets& tets) {
  AdaptiveMassSpring m;
  const long n = coarse.nodes();
  if (coarse.V.rows() != n) coarse.V.setZero(n, 3);
  if (coarse.F_ext.rows() != n) coarse.F_ext.setZero(n, 3);
  if (coarse.home_ks.size() != n) coarse.home_ks.setZero(n);
  if (coarse.home_kd.size() != n) coarse.home_kd.setZero(n);
  if (static_cast<long>(coarse.fixed.size()) != n) coarse.fixed.assign(n, 0);
  if (face_membrane.size() != F0.rows())
    throw std::invalid_argument("make_adaptive: one membrane modulus per surface face expected");
  const long nt = tets.T.rows();
  if (nt > 0 && (tets.E.size() != nt || tets.nu.size() != nt ||
                 !((tets.nu.array() > -1.0) && (tets.nu.array() < 0.5)).all() ||
                 tets.face_tet.size() != F0.rows() || (tets.T.array() < 0).any() ||
                 (tets.T.array() >= n).any() || (tets.face_tet.array() < 0).any() ||
                 (tets.face_tet.array() >= nt).any()))
    throw std::invalid_argument(
        "make_adaptive: tets, one modulus and one Poisson's ratio in (-1, 0.5) per tet, one tet "
        "per face");
  build_adjacency(coarse);
  m.coarse = std::move(coarse);
  m.F0 = std::move(F0);
  m.face_membrane = std::move(face_membrane);
  m.face_apex = Eigen::VectorXi::Constant(m.F0.rows(), -1);
  if (nt > 0) {
    m.tets = tets.T;
    m.face_tet = tets.face_tet;
    m.tet_ev.resize(nt);
    m.tet_estar = tets.E.array() / (1.0 - tets.nu.array().square());
    for (long t = 0; t < nt; ++t) {
      const Eigen::Vector3d a = m.coarse.X_rest.row(m.tets(t, 0)).transpose(),
                            b = m.coarse.X_rest.row(m.tets(t, 1)).transpose(),
                            c = m.coarse.X_rest.row(m.tets(t, 2)).transpose(),
                            d = m.coarse.X_rest.row(m.tets(t, 3)).transpose();
      m.tet_ev[t] = tets.E[t] * std::abs((d - a).dot((d - b).cross(d - c))) / 6.0;
    }
    for (long f = 0; f < m.F0.rows(); ++f)
      for (int k = 0; k < 4; ++k) {
        const int v = m.tets(m.face_tet[f], k);
        if (v != m.F0(f, 0) && v != m.F0(f, 1) && v != m.F0(f, 2)) m.face_apex[f] = v;
      }
    for (long f = 0; f < m.F0.rows(); ++f)
      for (int k = 0; k < 3; ++k) m.edge_tets[edge_key(m.F0(f, k), m.F0(f, (k + 1) % 3))];
    for (long t = 0; t < nt; ++t)
      for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) {
          auto it = m.edge_tets.find(edge_key(m.tets(t, i), m.tets(t, j)));
          if (it != m.edge_tets.end()) it->second.push_back(static_cast<int>(t));
        }
  }
  m.beta = beta;
  m.h_coarse = h_coarse;
  m.h = h_coarse;
  m.face_area = mesh_face_areas(m.coarse.X_rest, m.F0);
  m.node_area.setZero(n);
  for (long f = 0; f < m.F0.rows(); ++f)
    for (int k = 0; k < 3; ++k) m.node_area[m.F0(f, k)] += m.face_area[f];
  m.surface_area = m.node_area / 3.0;
  m.coarse_surface_area = m.surface_area;
  m.coarse_spring.reserve(m.coarse.springs.size() * 2);
  for (long k = 0; k < m.coarse.springs.size(); ++k)
    m.coarse_spring.emplace(edge_key(m.coarse.springs.E(k, 0), m.coarse.springs.E(k, 1)),
                            static_cast<int>(k));
  m.sys = m.coarse;
  m.F = m.F0;
  m.tris.reserve(m.F0.rows() * 2);
  for (long f = 0; f < m.F0.rows(); ++f)
    m.tris.push_back({{m.F0(f, 0), m.F0(f, 1), m.F0(f, 2)}, -1, 0, static_cast<int>(f)});
  m.node_level.assign(n, 0);
  m.mid_flag.assign(n, 0);
  return m;
}

Eigen::VectorXd mesh_face_areas(const RowMatX3d& X, const RowMatX3i& F) {
  Eigen::VectorXd a(F.rows());
  for (long f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d p = X.row(F(f, 0)).transpose();
    a[f] = 0.5 * (Eigen::Vector3d(X.row(F(f, 1)).transpose()) - p)
                     .cross(Eigen::Vector3d(X.row(F(f, 2)).transpose()) - p)
                     .norm();
  }
  return a;
}

bool refine_around(AdaptiveMassSpring& m, int node, const RefineParams& p) {
  if (p.policy == RefinePolicy::whole) return refine_whole(m, p.level);
  const size_t before = m.tris.size();
  // One-neighbourhood: leaves having the node as a corner or as a hanging midpoint on an edge.
  std::vector<int> ring;
  for (size_t t = 0; t < m.tris.size(); ++t) {
    const RefineTri& T = m.tris[t];
    if (T.child >= 0) continue;
    bool touch = false;
    for (int k = 0; k < 3; ++k)
      if (T.v[k] == node || find_mid(m, T.v[k], T.v[(k + 1) % 3]) == node) touch = true;
    if (touch) ring.push_back(static_cast<int>(t));
  }
  for (int t : ring) {
    if (p.policy == RefinePolicy::area_based)
      split_area(m, t, p);
    else
      split_to(m, t, p.level);
  }
  if (m.tris.size() == before) return false;
  close_mesh(m);
  rebuild(m);
  return true;
}

bool refine_whole(AdaptiveMassSpring& m, int level) {
  const size_t before = m.tris.size();
  for (long r = 0; r < m.F0.rows(); ++r) split_to(m, static_cast<int>(r), level);
  if (m.tris.size() == before) return false;
  close_mesh(m);
  rebuild(m);
  return true;
}

bool simplify(AdaptiveMassSpring& m) {
  if (m.tris.size() == static_cast<size_t>(m.F0.rows())) return false;
  const long N = m.coarse.nodes();
  MassSpringSystem& s = m.sys;
  // Keep the coarse nodes' current state; everything else comes back from the coarse copy.
  s.X.conservativeResize(N, 3);
  s.V.conservativeResize(N, 3);
  s.X_rest = m.coarse.X_rest;
  s.F_ext.conservativeResize(N, 3);
  s.mass = m.coarse.mass;
  s.home_ks = m.coarse.home_ks;
  s.home_kd = m.coarse.home_kd;
  s.fixed = m.coarse.fixed;
  s.springs = m.coarse.springs;
  s.adj_start = m.coarse.adj_start;
  s.adj_spring = m.coarse.adj_spring;
  m.F = m.F0;
  m.tris.resize(m.F0.rows());
  for (auto& t : m.tris) t.child = -1;
  m.midpoint.clear();
  m.midpoint_parents.clear();
  m.midpoint_root.clear();
  for (int e : m.flagged) m.mid_flag[e] = 0;
  m.flagged.clear();
  m.mid_flag.resize(N);
  m.node_level.resize(N);
  m.level = 0;
  m.h = m.h_coarse;
  m.new_nodes = m.new_springs = 0;
  m.surface_area = m.coarse_surface_area;
  return true;
}

}  // namespace palplab::engine
