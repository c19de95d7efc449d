#include "engine/models/fem_refine.hpp"

#include <algorithm>
#include <unordered_map>

namespace palplab::engine {

RedRefinement refine_red(const mesh::TetMesh& m) {
  const long nv = m.V.rows(), nt = m.T.rows();
  RedRefinement out;
  out.parent.reserve(static_cast<size_t>(nv));
  for (long i = 0; i < nv; ++i) out.parent.push_back({static_cast<int>(i), static_cast<int>(i)});
  // Midpoint of each edge, numbered in first-seen order (deterministic).
  std::unordered_map<long long, int> edge;
  edge.reserve(static_cast<size_t>(7 * nt));
  const auto mid = [&](int a, int b) {
    if (a > b) std::swap(a, b);
    const long long key = static_cast<long long>(a) * nv + b;
    const auto [it, inserted] = edge.try_emplace(key, static_cast<int>(out.parent.size()));
    if (inserted) out.parent.push_back({a, b});
    return it->second;
  };
  mesh::Tets T(8 * nt, 4);
  std::vector<std::array<int, 4>> kids(8);
  for (long t = 0; t < nt; ++t) {
    const int x0 = m.T(t, 0), x1 = m.T(t, 1), x2 = m.T(t, 2), x3 = m.T(t, 3);
    const int m01 = mid(x0, x1), m02 = mid(x0, x2), m03 = mid(x0, x3), m12 = mid(x1, x2),
              m13 = mid(x1, x3), m23 = mid(x2, x3);
    kids[0] = {x0, m01, m02, m03};
    kids[1] = {m01, x1, m12, m13};
    kids[2] = {m02, m12, x2, m23};
    kids[3] = {m03, m13, m23, x3};
    // The octahedron (m01, m02, m03, m12, m13, m23): three diagonals join opposite midpoints;
    // cut along the shortest one into four tets around it.
    const auto len2 = [&](int a, int b, int c, int d) {
      // |midpoint(a,b) - midpoint(c,d)|^2 * 4
      return (mesh::row3(m.V, a) + mesh::row3(m.V, b) - mesh::row3(m.V, c) - mesh::row3(m.V, d))
          .squaredNorm();
    };
    const double d0 = len2(x0, x1, x2, x3), d1 = len2(x0, x2, x1, x3), d2 = len2(x0, x3, x1, x2);
    int a, b;              // the diagonal
    std::array<int, 4> r;  // the ring of the other four midpoints, in cyclic order
    if (d0 <= d1 && d0 <= d2) {
      a = m01, b = m23, r = {m02, m03, m13, m12};
    } else if (d1 <= d2) {
      a = m02, b = m13, r = {m01, m03, m23, m12};
    } else {
      a = m03, b = m12, r = {m01, m02, m23, m13};
    }
    for (int k = 0; k < 4; ++k) kids[4 + k] = {a, b, r[k], r[(k + 1) % 4]};
    for (int k = 0; k < 8; ++k) T.row(8 * t + k) << kids[k][0], kids[k][1], kids[k][2], kids[k][3];
  }
  mesh::Positions V(static_cast<long>(out.parent.size()), 3);
  for (size_t i = 0; i < out.parent.size(); ++i)
    V.row(static_cast<long>(i)) = 0.5 * (m.V.row(out.parent[i][0]) + m.V.row(out.parent[i][1]));
  // Orientation: a child of a positive tet may come out negative (the ring order above is
  // cyclic but its sense depends on the diagonal); swap two vertices where it does.
  for (long t = 0; t < T.rows(); ++t)
    if (mesh::signed_volume(V, T, static_cast<int>(t)) < 0) std::swap(T(t, 2), T(t, 3));
  Eigen::VectorXi attr;
  if (m.attribute.size() == nt) {
    attr.resize(8 * nt);
    for (long t = 0; t < nt; ++t) attr.segment<8>(8 * t).setConstant(m.attribute[t]);
  }
  mesh::Regions reg;
  if (!m.regions.empty() && m.regions.id.size() == nt) {
    reg.names = m.regions.names;
    reg.id.resize(8 * nt);
    for (long t = 0; t < nt; ++t) reg.id.segment<8>(8 * t).setConstant(m.regions.id[t]);
  }
  out.parent_tet.resize(static_cast<size_t>(8 * nt));
  for (long t = 0; t < 8 * nt; ++t)
    out.parent_tet[static_cast<size_t>(t)] = static_cast<int>(t / 8);
  out.mesh = mesh::make_tet_mesh(std::move(V), std::move(T), std::move(attr), std::move(reg));
  return out;
}

mesh::SurfaceMesh refine_surface_near(const mesh::SurfaceMesh& s, const Eigen::Vector3d& point,
                                      double radius, int rounds) {
  std::vector<Eigen::Vector3d> V;
  for (long i = 0; i < s.V.rows(); ++i) V.push_back(mesh::row3(s.V, i));
  std::vector<std::array<int, 3>> F;
  for (long k = 0; k < s.F.rows(); ++k) F.push_back({s.F(k, 0), s.F(k, 1), s.F(k, 2)});
  std::vector<int> region;
  const bool has_regions = !s.regions.empty() && s.regions.id.size() == s.F.rows();
  for (long k = 0; has_regions && k < s.F.rows(); ++k) region.push_back(s.regions.id[k]);
  const auto key = [](int a, int b) {
    if (a > b) std::swap(a, b);
    return (static_cast<long long>(a) << 32) | static_cast<unsigned>(b);
  };
  for (int round = 0; round < rounds; ++round) {
    const double r = radius * (rounds - round) / rounds;
    std::vector<char> red(F.size(), 0);
    std::unordered_map<long long, int> split;  // edge -> midpoint index (-1 until created)
    for (size_t k = 0; k < F.size(); ++k) {
      const Eigen::Vector3d c = (V[F[k][0]] + V[F[k][1]] + V[F[k][2]]) / 3;
      double size = 0;
      for (int j = 0; j < 3; ++j) size = std::max(size, (V[F[k][j]] - c).norm());
      if ((c - point).norm() > r + size) continue;
      red[k] = 1;
      for (int j = 0; j < 3; ++j) split.try_emplace(key(F[k][j], F[k][(j + 1) % 3]), -1);
    }
    // Closure: a face with two or more split edges becomes red (its third edge splits too).
    for (bool changed = true; changed;) {
      changed = false;
      for (size_t k = 0; k < F.size(); ++k) {
        if (red[k]) continue;
        int n = 0;
        for (int j = 0; j < 3; ++j) n += split.count(key(F[k][j], F[k][(j + 1) % 3])) > 0;
        if (n < 2) continue;
        red[k] = 1;
        changed = true;
        for (int j = 0; j < 3; ++j) split.try_emplace(key(F[k][j], F[k][(j + 1) % 3]), -1);
      }
    }
    const auto mid = [&](int a, int b) {
      int& m = split.at(key(a, b));
      if (m < 0) {
        m = static_cast<int>(V.size());
        V.push_back(0.5 * (V[a] + V[b]));
      }
      return m;
    };
    std::vector<std::array<int, 3>> F2;
    std::vector<int> region2;
    for (size_t k = 0; k < F.size(); ++k) {
      const auto [a, b, c] = F[k];
      const size_t before = F2.size();
      if (red[k]) {
        const int ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
        F2.push_back({a, ab, ca});
        F2.push_back({ab, b, bc});
        F2.push_back({ca, bc, c});
        F2.push_back({ab, bc, ca});
      } else {
        int j = 0;
        while (j < 3 && !split.count(key(F[k][j], F[k][(j + 1) % 3]))) ++j;
        if (j == 3) {
          F2.push_back(F[k]);
        } else {  // green: bisect edge (x, y) from the opposite vertex z, same orientation
          const int x = F[k][j], y = F[k][(j + 1) % 3], z = F[k][(j + 2) % 3];
          const int m = mid(x, y);
          F2.push_back({x, m, z});
          F2.push_back({m, y, z});
        }
      }
      if (has_regions) region2.insert(region2.end(), F2.size() - before, region[k]);
    }
    F = std::move(F2);
    region = std::move(region2);
  }
  mesh::Positions P(static_cast<long>(V.size()), 3);
  for (size_t i = 0; i < V.size(); ++i) P.row(static_cast<long>(i)) = V[i].transpose();
  mesh::Faces G(static_cast<long>(F.size()), 3);
  for (size_t k = 0; k < F.size(); ++k) G.row(static_cast<long>(k)) << F[k][0], F[k][1], F[k][2];
  mesh::SurfaceMesh out = mesh::make_surface_mesh(std::move(P), std::move(G));
  if (has_regions) {
    out.regions.names = s.regions.names;
    out.regions.id =
        Eigen::Map<const Eigen::VectorXi>(region.data(), static_cast<long>(region.size()));
  }
  return out;
}

}  // namespace palplab::engine
