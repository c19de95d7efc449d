#include "engine/models/contact_pad.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace palplab::engine {

void build_pad_surface(const RowMatX3i& F, long nodes, PadSurface& out) {
  out.F = F;
  out.nodes = nodes;
  const long nf = F.rows();
  out.node_start.assign(nodes + 1, 0);
  for (long f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) ++out.node_start[F(f, k) + 1];
  for (long i = 0; i < nodes; ++i) out.node_start[i + 1] += out.node_start[i];
  out.node_faces.assign(out.node_start[nodes], 0);
  std::vector<int> fill(out.node_start.begin(), out.node_start.end() - 1);
  for (long f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) out.node_faces[fill[F(f, k)]++] = static_cast<int>(f);
  // The face across edge (a, b) opposite vertex k: the other face of a's fan holding b.
  out.across.setConstant(nf, 3, -1);
  for (long f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, (k + 1) % 3), b = F(f, (k + 2) % 3);
      for (int q = out.node_start[a]; q < out.node_start[a + 1]; ++q) {
        const int g = out.node_faces[q];
        if (g == f) continue;
        if (F(g, 0) == b || F(g, 1) == b || F(g, 2) == b) {
          out.across(f, k) = g;
          break;
        }
      }
    }
}

namespace {

// The face under 2-d point (u, v) of the disc's plane (coordinates along e1, e2), walking from
// `f` towards it across the edge of the most negative barycentric weight; -1 when the walk
// leaves the surface or reaches a face seen from behind (the disc overhangs there).
int locate(const PadSurface& s, const RowMatX3d& X, const Eigen::Vector3d& e1,
           const Eigen::Vector3d& e2, double u, double v, int f, Eigen::Vector3d& b) {
  constexpr int kMaxHops = 256;
  for (int hop = 0; hop < kMaxHops && f >= 0; ++hop) {
    double pu[3], pv[3];
    for (int k = 0; k < 3; ++k) {
      const auto x = X.row(s.F(f, k));
      pu[k] = x.dot(e1.transpose()) - u;
      pv[k] = x.dot(e2.transpose()) - v;
    }
    // Twice the signed areas of the sub-triangles opposite each vertex (point at the origin).
    const double l0 = pu[1] * pv[2] - pu[2] * pv[1];
    const double l1 = pu[2] * pv[0] - pu[0] * pv[2];
    const double l2 = pu[0] * pv[1] - pu[1] * pv[0];
    const double area = l0 + l1 + l2;
    if (!(area > 0.0)) return -1;  // seen edge-on or from behind
    const double tol = -1e-12 * area;
    int k = 0;
    double lo = l0;
    if (l1 < lo) lo = l1, k = 1;
    if (l2 < lo) lo = l2, k = 2;
    if (lo >= tol) {
      b = Eigen::Vector3d(std::max(l0, 0.0), std::max(l1, 0.0), std::max(l2, 0.0));
      b /= b.sum();
      return f;
    }
    f = s.across(f, k);
  }
  return -1;
}

// cos t and sin t of every quadrature point's angle, ring by ring (point q of ring j, m = 6 (j + 1)
// points: t = (j odd) pi / m + 2 pi q / m, alternate rings staggered).
struct UnitDir {
  double c, s;
};
std::vector<UnitDir> disc_directions(int rings) {
  std::vector<UnitDir> dirs;
  for (int j = 0; j < rings; ++j) {
    const int m = 6 * (j + 1);
    const double phase = (j % 2) * std::numbers::pi / m;
    for (int q = 0; q < m; ++q) {
      const double t = phase + 2 * std::numbers::pi * q / m;
      dirs.push_back({std::cos(t), std::sin(t)});
    }
  }
  return dirs;
}

}  // namespace

int disc_pad(const PadSurface& s, const RowMatX3d& X, const Eigen::Vector3d& centre,
             const Eigen::Vector3d& n, double radius, int start, std::vector<PadPoint>& out,
             int rings) {
  out.clear();
  if (start < 0 || start >= s.F.rows()) return -1;
  // The disc's frame: e1 from the world axis least along n (fixed in the world, like the probe).
  const Eigen::Vector3d a =
      std::abs(n.x()) < 0.8 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d e1 = (a - a.dot(n) * n).normalized();
  const Eigen::Vector3d e2 = n.cross(e1);
  const double cu = centre.dot(e1), cv = centre.dot(e2);
  Eigen::Vector3d b;
  const int fc = locate(s, X, e1, e2, cu, cv, start, b);
  if (fc < 0) return -1;
  // The shipped ring count's directions once (disc_pad runs every haptic step); others per call.
  static const std::vector<UnitDir> kDirs = disc_directions(kPadRings);
  const std::vector<UnitDir> other =
      rings == kPadRings ? std::vector<UnitDir>{} : disc_directions(rings);
  const std::vector<UnitDir>& dirs = rings == kPadRings ? kDirs : other;
  int prev = fc;  // the face of the last point found: the next point is a few mm away
  for (int j = 0, d = 0; j < rings; ++j) {
    const double r = radius * std::sqrt((j + 0.5) / rings);
    const int m = 6 * (j + 1);
    const double w = 1.0 / (rings * m);
    for (int q = 0; q < m; ++q, ++d) {
      const double u = cu + r * dirs[d].c, v = cv + r * dirs[d].s;
      // From the last point's face (few hops); from the centre's face if that walk fails (it
      // may meet a face seen from behind that the straight walk from the centre does not).
      int f = locate(s, X, e1, e2, u, v, prev, b);
      if (f < 0 && prev != fc) f = locate(s, X, e1, e2, u, v, fc, b);
      if (f < 0) continue;  // off the surface: no load
      prev = f;
      Eigen::Vector3d y = Eigen::Vector3d::Zero();
      for (int k = 0; k < 3; ++k) y += b[k] * X.row(s.F(f, k)).transpose();
      const double yield = std::max(0.0, (y - centre).dot(n));
      for (int k = 0; k < 3; ++k) {
        if (!(b[k] > 0.0)) continue;
        const int i = s.F(f, k);
        out.push_back({i, w * b[k], (X.row(i).transpose() - y).dot(n) + yield});
      }
    }
  }
  return fc;
}

}  // namespace palplab::engine
