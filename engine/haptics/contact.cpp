#include "engine/haptics/contact.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace palplab::engine {

namespace {

using Vec3 = Eigen::Vector3d;

// The Phong projection is used where every 1 - t kappa_i >= kMinReach (see follow), so it moves
// the proxy by at most kGain times the device's tangential motion. Per step the walk may move the
// proxy by kTrack times the projection's local gain 1 / (1 - t kappa) (at the proxy, at most
// kGain) times the device's motion tangential to the contact normal -- the margin covers the
// change of the gain within a step -- plus kAllow mean edges, which lets a proxy that lags the
// projection (after following the device near a centre of curvature, or after a capped walk)
// catch up, and a walk cut short by the bound finish while the device holds still. Measured on
// the 2.5 N slides over the left ovaries (issue 9): kAllow 1 % of an edge (65 um a step on C)
// moved the force by up to 0.13 N a step while the proxy caught up 3-7 mm; 0.2 % keeps it below
// 0.06 N (0.4 %: 0.06 N on C and D).
constexpr double kMinReach = 0.25, kGain = 1.0 / kMinReach, kTrack = 1.25, kAllow = 0.002,
                 kEntryAllow = 0.01;

// Closest point of triangle abc to x with its barycentric weights (Ericson, Real-Time Collision
// Detection, 5.1.5): exact on the vertex, edge and face regions.
Vec3 closest_on_triangle(const Vec3& x, const Vec3& a, const Vec3& b, const Vec3& c, Vec3& w) {
  const Vec3 ab = b - a, ac = c - a, ax = x - a;
  const double d1 = ab.dot(ax), d2 = ac.dot(ax);
  if (d1 <= 0 && d2 <= 0) {
    w = {1, 0, 0};
    return a;
  }
  const Vec3 bx = x - b;
  const double d3 = ab.dot(bx), d4 = ac.dot(bx);
  if (d3 >= 0 && d4 <= d3) {
    w = {0, 1, 0};
    return b;
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    w = {1 - v, v, 0};
    return a + v * ab;
  }
  const Vec3 cx = x - c;
  const double d5 = ab.dot(cx), d6 = ac.dot(cx);
  if (d6 >= 0 && d5 <= d6) {
    w = {0, 0, 1};
    return c;
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double t = d2 / (d2 - d6);
    w = {1 - t, 0, t};
    return a + t * ac;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    w = {0, 1 - t, t};
    return b + t * (c - b);
  }
  const double den = va + vb + vc;
  if (!(den > 0)) {  // degenerate (zero-area) triangle: its vertex nearest to x
    const double da = (x - a).squaredNorm(), db = (x - b).squaredNorm(), dc = (x - c).squaredNorm();
    if (da <= db && da <= dc) {
      w = {1, 0, 0};
      return a;
    }
    w = db <= dc ? Vec3(0, 1, 0) : Vec3(0, 0, 1);
    return db <= dc ? b : c;
  }
  const double v = vb / den, u = vc / den;
  w = {1 - v - u, v, u};
  return a + v * ab + u * ac;
}

}  // namespace

namespace {

// Top-down median split on the longest axis of the face boxes' centres; leaves of <= 4 faces.
int build_bvh(FaceIndex& ix, int begin, int end) {
  const int id = static_cast<int>(ix.bvh.size());
  ix.bvh.push_back({});
  Eigen::AlignedBox3d box, centres;
  box.setEmpty();
  centres.setEmpty();
  for (int k = begin; k < end; ++k) {
    box.extend(ix.face_box[ix.order[k]]);
    centres.extend(ix.face_box[ix.order[k]].center());
  }
  ix.bvh[id].box = box;
  ix.bvh[id].begin = begin;
  ix.bvh[id].end = end;
  if (end - begin > 4) {
    int axis = 0;
    centres.sizes().maxCoeff(&axis);
    const int mid = (begin + end) / 2;
    std::nth_element(ix.order.begin() + begin, ix.order.begin() + mid, ix.order.begin() + end,
                     [&](int a, int b) {
                       return ix.face_box[a].center()[axis] < ix.face_box[b].center()[axis];
                     });
    const int l = build_bvh(ix, begin, mid);
    const int r = build_bvh(ix, mid, end);
    ix.bvh[id].left = l;
    ix.bvh[id].right = r;
  }
  return id;
}

// The barycentric weights, on face g, of the point with weights w on face f's edge opposite
// corner exit_k (the edge f and g share): the walk's crossing into the next face. A zero sum
// means the point has no weight on that edge (a degenerate crossing).
Vec3 weights_across(const mesh::Faces& F, int f, int g, int exit_k, const Vec3& w) {
  const int a = (exit_k + 1) % 3, b = (exit_k + 2) % 3;
  Vec3 wg = Vec3::Zero();
  for (int k = 0; k < 3; ++k) wg[k] = F(g, k) == F(f, a) ? w[a] : F(g, k) == F(f, b) ? w[b] : 0.0;
  return wg;
}

}  // namespace

std::vector<Eigen::AlignedBox3d> face_boxes(const mesh::Positions& V, const mesh::Faces& F) {
  // Each box as AlignedBox::extend makes it from an empty one: per coordinate std::min/std::max
  // (Eigen's cwiseMin/cwiseMax on scalars) from lowest/highest over the three corners in order,
  // so the same bits; on the raw row-major arrays, each box constructed once.
  std::vector<Eigen::AlignedBox3d> b;
  b.reserve(static_cast<std::size_t>(F.rows()));
  const double* v = V.data();
  const int* f = F.data();
  const double top = std::numeric_limits<double>::max(),
               bottom = std::numeric_limits<double>::lowest();
  for (long i = 0; i < F.rows(); ++i, f += 3) {
    double lo[3] = {top, top, top}, hi[3] = {bottom, bottom, bottom};
    for (int k = 0; k < 3; ++k) {
      const double* p = v + 3 * static_cast<long>(f[k]);
      for (int c = 0; c < 3; ++c) {
        lo[c] = std::min(lo[c], p[c]);
        hi[c] = std::max(hi[c], p[c]);
      }
    }
    b.emplace_back(Eigen::Vector3d(lo[0], lo[1], lo[2]), Eigen::Vector3d(hi[0], hi[1], hi[2]));
  }
  return b;
}

bool surface_closed(const mesh::Faces& F, const std::vector<int>& ef) {
  const long nf = F.rows();
  if (nf == 0 || static_cast<long>(ef.size()) != 3 * nf) return false;
  const int* Fp = F.data();  // row-major #F by 3
  static constexpr int next[3] = {1, 2, 0}, prev[3] = {2, 0, 1};
  bool ok = true;  // no early exit inside a face: the loop stays branch-light
  for (long f = 0; f < nf && ok; ++f) {
    const int* a = Fp + 3 * f;
    ok = a[0] != a[1] && a[1] != a[2] && a[2] != a[0];
    for (int k = 0; k < 3; ++k) {
      // The face g across f's edge u -> v must run it v -> u and name f across it.
      const int g = ef[3 * f + k];
      if (static_cast<unsigned>(g) >= static_cast<unsigned long>(nf)) return false;
      const int u = a[next[k]], v = a[prev[k]];
      const int* b = Fp + 3 * static_cast<long>(g);
      const int j = b[0] == v ? 0 : b[1] == v ? 1 : b[2] == v ? 2 : -1;
      if (j < 0) return false;
      ok = ok && b[next[j]] == u && ef[3 * static_cast<long>(g) + prev[j]] == f;
    }
  }
  return ok;
}

FaceIndex build_face_index(const mesh::Positions& V, const mesh::Faces& F) {
  FaceIndex ix;
  const long nv = V.rows(), nf = F.rows();
  ix.vf_offset.assign(nv + 1, 0);
  for (long f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) ++ix.vf_offset[F(f, k) + 1];
  for (long i = 0; i < nv; ++i) ix.vf_offset[i + 1] += ix.vf_offset[i];
  ix.vf.resize(ix.vf_offset[nv]);
  std::vector<int> fill(ix.vf_offset.begin(), ix.vf_offset.end() - 1);
  for (long f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) ix.vf[fill[F(f, k)]++] = static_cast<int>(f);
  // Face across each edge: edge_face[3 f + k] is the face sharing the edge opposite corner k.
  ix.edge_face.assign(3 * nf, -1);
  for (long f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const int u = F(f, (k + 1) % 3), v = F(f, (k + 2) % 3);
      for (int j = ix.vf_offset[u]; j < ix.vf_offset[u + 1] && ix.edge_face[3 * f + k] < 0; ++j) {
        const int g = ix.vf[j];
        if (g == f) continue;
        for (int m = 0; m < 3; ++m)
          if (F(g, m) == v) ix.edge_face[3 * f + k] = g;
      }
    }
  double edges = 0.0;
  for (long f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k)
      edges += (mesh::row3(V, F(f, k)) - mesh::row3(V, F(f, (k + 1) % 3))).norm();
  ix.mean_edge = nf > 0 ? edges / (3.0 * nf) : 0.0;
  ix.face_box = face_boxes(V, F);
  ix.order.resize(nf);
  std::iota(ix.order.begin(), ix.order.end(), 0);
  ix.bvh.reserve(2 * nf / 4 + 2);
  if (nf > 0) build_bvh(ix, 0, static_cast<int>(nf));
  ix.closed = surface_closed(F, ix.edge_face);
  return ix;
}

namespace {
// Whole-array scans without an early exit, so that the compiler vectorises them (a stored index
// is checked on every .psim load; a damaged one is rare): some v[i] outside [lo, hi).
bool any_outside(const std::vector<int>& v, long lo, long hi) {
  const auto width = static_cast<std::uint32_t>(hi - lo);
  const auto base = static_cast<std::uint32_t>(lo);
  std::uint32_t bad = 0;
  for (int x : v) bad |= static_cast<std::uint32_t>(x) - base >= width;
  return bad != 0;
}
}  // namespace

std::string check_face_index(const FaceIndex& ix, long nv, long nf) {
  if (static_cast<long>(ix.vf_offset.size()) != nv + 1 || ix.vf_offset.front() != 0 ||
      ix.vf_offset.back() != static_cast<long>(ix.vf.size()) ||
      static_cast<long>(ix.vf.size()) != 3 * nf)
    return "vertex-face table does not match the surface";
  std::uint32_t decrease = 0;
  for (long i = 0; i < nv; ++i) decrease |= ix.vf_offset[i + 1] < ix.vf_offset[i];
  if (decrease) return "vertex-face table is not monotone";
  if (any_outside(ix.vf, 0, nf)) return "vertex-face table: face out of range";
  if (static_cast<long>(ix.edge_face.size()) != 3 * nf)
    return "edge-face table does not match the surface";
  if (any_outside(ix.edge_face, -1, nf)) return "edge-face table: face out of range";
  if (!std::isfinite(ix.mean_edge) || ix.mean_edge < 0) return "bad mean edge";
  if (static_cast<long>(ix.face_box.size()) != nf || static_cast<long>(ix.order.size()) != nf)
    return "face boxes or order do not match the surface";
  if (any_outside(ix.order, 0, nf)) return "face order is not a permutation of the faces";
  std::vector<unsigned char> seen(static_cast<std::size_t>(nf), 0);
  unsigned char twice = 0;
  for (int f : ix.order) {
    twice |= seen[f];
    seen[f] = 1;
  }
  if (twice) return "face order is not a permutation of the faces";
  if ((nf > 0) != !ix.bvh.empty()) return "face hierarchy does not match the surface";
  // A tree: every child index is later than its parent (the builder's pre-order) and no node is
  // the child of two, so a walk from the root visits each node at most once; runs lie inside
  // [0, #F] and children split their parent's run.
  const long nb = static_cast<long>(ix.bvh.size());
  std::vector<char> has_parent(nb, 0);
  for (long i = 0; i < nb; ++i) {
    const FaceIndex::Node& n = ix.bvh[i];
    if (n.begin < 0 || n.end < n.begin || n.end > nf) return "face hierarchy: run out of range";
    if ((n.left < 0) != (n.right < 0)) return "face hierarchy: node with one child";
    if (n.left >= 0) {
      if (n.left <= i || n.right <= i || n.left >= nb || n.right >= nb)
        return "face hierarchy: child out of range";
      if (has_parent[n.left] || has_parent[n.right] || n.left == n.right)
        return "face hierarchy: a node has two parents";
      has_parent[n.left] = has_parent[n.right] = 1;
      const FaceIndex::Node &l = ix.bvh[n.left], &r = ix.bvh[n.right];
      if (l.begin != n.begin || l.end != r.begin || r.end != n.end)
        return "face hierarchy: children do not split their parent";
    }
  }
  if (nb > 0 && (ix.bvh[0].begin != 0 || ix.bvh[0].end != nf))
    return "face hierarchy: the root does not hold every face";
  return "";
}

ContactTracker::ContactTracker(const mesh::Positions& V, const mesh::Positions& N,
                               const mesh::Faces& F)
    : ContactTracker(V, N, F, std::make_shared<const FaceIndex>(build_face_index(V, F))) {}

ContactTracker::ContactTracker(const mesh::Positions& V, const mesh::Positions& N,
                               const mesh::Faces& F, std::shared_ptr<const FaceIndex> index)
    : V_(V), N_(N), F_(F), index_(std::move(index)), ix_(*index_) {
  stack_.reserve(64);
}

void ContactTracker::reset() {
  engaged_ = outside_known_ = started_inside_ = false;
  node_ = -1;
  proxy_ = SurfacePoint{};
  depth_ = 0.0;
}

void ContactTracker::invalidate() {
  reset();
}

int ContactTracker::node() const {
  return engaged_ ? node_ : -1;
}

SurfacePoint ContactTracker::closest_on_face(int f, const Vec3& x) const {
  SurfacePoint s;
  s.face = f;
  s.p = closest_on_triangle(x, mesh::row3(V_, F_(f, 0)), mesh::row3(V_, F_(f, 1)),
                            mesh::row3(V_, F_(f, 2)), s.w);
  return s;
}

SurfacePoint ContactTracker::closest_point(const Vec3& x) const {
  SurfacePoint best;
  double bd = INFINITY;
  for (long f = 0; f < F_.rows(); ++f) {
    if (ix_.face_box[f].squaredExteriorDistance(x) >= bd) continue;
    const SurfacePoint s = closest_on_face(static_cast<int>(f), x);
    const double d = (s.p - x).squaredNorm();
    if (d < bd) {
      bd = d;
      best = s;
    }
  }
  return best;
}

double ContactTracker::winding_number(const Vec3& x) const {
  // Outside the bounding box of a closed, consistently oriented surface the winding number is 0
  // exactly: the surface's faces then pair up edge by edge with opposite directions (a 2-cycle
  // with no boundary), so the winding number is an integer constant on each component of the
  // complement, and the box's outside is one connected region reaching infinity, where it is 0.
  // A scene's first step starts the device below the organ (scene.cpp start_position), outside
  // that box: the sum over every face below was a seventh of loading prototype A from a .psim
  // file (perf). Whether the surface is closed is a property of the index (FaceIndex::closed,
  // surface_closed: decided once when the index is built, stored in a .psim file); a surface
  // with a hole, a duplicated, degenerate or flipped face, or a non-manifold edge takes the sum,
  // which is robust to those.
  const long nf = F_.rows();
  if (nf > 0 && V_.rows() > 0) {
    const Eigen::RowVector3d lo = V_.colwise().minCoeff(), hi = V_.colwise().maxCoeff();
    const bool outside_box = x.x() < lo.x() || x.y() < lo.y() || x.z() < lo.z() || x.x() > hi.x() ||
                             x.y() > hi.y() || x.z() > hi.z();
    if (outside_box && ix_.closed) return 0.0;
  }
  // Sum of the signed solid angles of the faces seen from x (Van Oosterom & Strackee 1983),
  // over 4 pi. Robust for a surface with small holes or duplicated faces (fractional values).
  double omega = 0.0;
  for (long f = 0; f < F_.rows(); ++f) {
    const Vec3 a = mesh::row3(V_, F_(f, 0)) - x, b = mesh::row3(V_, F_(f, 1)) - x,
               c = mesh::row3(V_, F_(f, 2)) - x;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double num = a.dot(b.cross(c));
    const double den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    omega += 2.0 * std::atan2(num, den);
  }
  return omega / (4.0 * M_PI);
}

bool ContactTracker::first_entry(const Vec3& a, const Vec3& b, SurfacePoint& hit) const {
  if (ix_.bvh.empty()) return false;
  const Vec3 d = b - a;
  Eigen::AlignedBox3d seg(a.cwiseMin(b), a.cwiseMax(b));
  const double pad = 1e-12 * (1.0 + a.cwiseAbs().maxCoeff() + b.cwiseAbs().maxCoeff());
  seg.min().array() -= pad;
  seg.max().array() += pad;
  double best_t = INFINITY;
  stack_.clear();
  stack_.push_back(0);
  while (!stack_.empty()) {
    const FaceIndex::Node& nd = ix_.bvh[stack_.back()];
    stack_.pop_back();
    if (!nd.box.intersects(seg)) continue;
    if (nd.left >= 0) {
      stack_.push_back(nd.left);
      stack_.push_back(nd.right);
      continue;
    }
    for (int k = nd.begin; k < nd.end; ++k) {
      const int f = ix_.order[k];
      if (!ix_.face_box[f].intersects(seg)) continue;
      // Moller-Trumbore; only a crossing from the outside (against the face normal) counts. The
      // weights are accepted with a small tolerance so a path through an edge or a vertex is
      // caught by one of the faces there.
      const Vec3 p0 = mesh::row3(V_, F_(f, 0));
      const Vec3 e1 = mesh::row3(V_, F_(f, 1)) - p0, e2 = mesh::row3(V_, F_(f, 2)) - p0;
      if (e1.cross(e2).dot(d) >= 0.0) continue;  // leaving, grazing or degenerate
      const Vec3 pv = d.cross(e2);
      const double det = e1.dot(pv);
      if (det == 0.0) continue;
      const double inv = 1.0 / det;
      const Vec3 tv = a - p0;
      const double u = tv.dot(pv) * inv;
      const Vec3 qv = tv.cross(e1);
      const double v = d.dot(qv) * inv;
      const double t = e2.dot(qv) * inv;
      constexpr double eps = 1e-9;
      if (u < -eps || v < -eps || u + v > 1 + eps || t < -eps || t > 1 + eps) continue;
      if (t < best_t) {
        best_t = t;
        hit.face = f;
        const double uu = std::clamp(u, 0.0, 1.0), vv = std::clamp(v, 0.0, 1.0 - uu);
        hit.w = Vec3(1 - uu - vv, uu, vv);
        hit.p = p0 + uu * e1 + vv * e2;
      }
    }
  }
  return best_t < INFINITY;
}

SurfacePoint ContactTracker::walk(const SurfacePoint& from, const Vec3& x) const {
  return walk(from, x, INFINITY, nullptr);
}

SurfacePoint ContactTracker::walk(const SurfacePoint& from, const Vec3& x, double max_travel,
                                  WalkInfo* info) const {
  // Phong projection: the proxy p on the surface whose shaded normal passes through x,
  // x = p - t m(p) with m = sum_i w_i N_i (the unnormalised shaded normal; n = m / |m|, depth
  // t |m|). Under a straight push along a node's normal the proxy stays on the node (a
  // deformable tissue keeps its contact node); sliding moves it continuously, since m is
  // continuous over edges.
  //
  // Newton's method on the three unknowns (u, v, t) of the face (u = w1, v = w2): the residual
  // r = p(u, v) - t m(u, v) - x is quadratic in them, so Newton converges quadratically whatever
  // the depth, up to the focal points of the surface where its Jacobian
  // J = [e1 - t dN1, e2 - t dN2, -m] is singular. (The former fixed point -- m from the current
  // weights, x projected onto the face plane along it -- contracts by t |dm/dp| per iteration:
  // on C's ovary tip, a cap of radius ~9 mm, it did not converge at the 9.3 mm a 2.5 N press
  // holds there.) Each step is cut at the face's boundary, where the walk crosses to the face
  // across that edge (the same point, so p moves continuously), and backtracked until |r|
  // decreases (Armijo): |r| decreases monotonically along the walk. The path of p is at most
  // `max_travel` long (a trust region: the proxy cannot run off far in one step).
  int f = from.face;
  Vec3 w = from.w.cwiseMax(0.0);
  w = w.sum() > 0 ? Vec3(w / w.sum()) : Vec3(1.0 / 3, 1.0 / 3, 1.0 / 3);
  const auto at = [&](int face, const Vec3& wt, double t, Vec3& p, Vec3& m) {
    p = m = Vec3::Zero();
    for (int k = 0; k < 3; ++k) {
      p += wt[k] * mesh::row3(V_, F_(face, k));
      m += wt[k] * mesh::row3(N_, F_(face, k));
    }
    return Vec3(p - t * m - x);
  };
  Vec3 p, m;
  at(f, w, 0.0, p, m);
  double t = m.squaredNorm() > 0 ? (p - x).dot(m) / m.squaredNorm() : 0.0;
  // Converged at 1e-12 of a mean edge (Newton gets there in a few iterations); a walk that
  // stops on rounding (no decrease) within 1e-9 of an edge (a few picometres on the organs) is
  // converged too.
  const double tol = 1e-12 * std::max(ix_.mean_edge, 1e-300) + 1e-16 * x.norm();
  const double loose = 1e-9 * std::max(ix_.mean_edge, 1e-300) + 1e-15 * x.norm();
  double travelled = 0.0;
  int back_face = -1, still_crossings = 0, it = 0;
  bool converged = false, capped = false;
  for (; it < 100; ++it) {
    const Vec3 r = at(f, w, t, p, m);
    const double phi = r.squaredNorm();
    if (!(phi > tol * tol)) {
      converged = std::isfinite(phi);
      break;
    }
    const Vec3 a = mesh::row3(V_, F_(f, 0)), na = mesh::row3(N_, F_(f, 0));
    Eigen::Matrix3d J;
    J.col(0) = (mesh::row3(V_, F_(f, 1)) - a) - t * (mesh::row3(N_, F_(f, 1)) - na);
    J.col(1) = (mesh::row3(V_, F_(f, 2)) - a) - t * (mesh::row3(N_, F_(f, 2)) - na);
    J.col(2) = -m;
    Vec3 d = J.partialPivLu().solve(-r);
    const double scale = J.col(0).norm() * J.col(1).norm() * J.col(2).norm();
    if (!d.allFinite() || !(std::abs(J.determinant()) > 1e-12 * scale)) {
      // At a focal point: a Levenberg-Marquardt step (a descent direction for |r|^2).
      const Eigen::Matrix3d A = J.transpose() * J;
      d = (A + 1e-8 * A.trace() * Eigen::Matrix3d::Identity()).ldlt().solve(-J.transpose() * r);
      if (!d.allFinite()) break;
    }
    const Vec3 dw(-d[0] - d[1], d[0], d[1]);
    // The largest step inside the face, and inside the trust region.
    double amax = 1.0;
    int exit_k = -1;
    for (int k = 0; k < 3; ++k)
      if (dw[k] < 0.0 && w[k] + dw[k] < 0.0 && w[k] / -dw[k] < amax) {
        amax = w[k] / -dw[k];
        exit_k = k;
      }
    const Vec3 dp = d[0] * (mesh::row3(V_, F_(f, 1)) - a) + d[1] * (mesh::row3(V_, F_(f, 2)) - a);
    const double dpn = dp.norm();
    if (travelled + amax * dpn > max_travel) {
      amax = dpn > 0 ? std::max(0.0, (max_travel - travelled) / dpn) : 0.0;
      exit_k = -1;
      capped = true;
    }
    double al = amax;
    Vec3 wn = w, pn, mn;
    bool ok = false;
    for (int ls = 0; ls < 40; ++ls) {
      wn = (w + al * dw).cwiseMax(0.0);
      wn /= wn.sum();
      const double phin = at(f, wn, t + al * d[2], pn, mn).squaredNorm();
      if (phin <= (1.0 - 1e-4 * al) * phi) {
        ok = true;
        break;
      }
      al *= 0.5;
      exit_k = -1;
      capped = false;
    }
    if (!ok) {  // no decrease along the Newton direction: rounding, or a fold
      converged = phi <= loose * loose;
      break;
    }
    travelled += al * dpn;
    w = wn;
    t += al * d[2];
    if (capped) break;
    if (exit_k < 0) continue;
    // On the edge opposite corner exit_k: continue in the face across it, from the same point.
    const int g = ix_.edge_face[3 * f + exit_k];
    if (g < 0) break;  // a boundary: stay on the edge
    still_crossings = al * dpn > 0.0 ? 0 : still_crossings + 1;
    // Back and forth over one edge without moving (the two faces' solutions lie on each other's
    // side: a fold), or round a vertex: stay.
    if ((still_crossings > 1 && g == back_face) || still_crossings > 16) break;
    const Vec3 wg = weights_across(F_, f, g, exit_k, w);
    if (!(wg.sum() > 0)) break;
    back_face = f;
    f = g;
    w = wg / wg.sum();
  }
  // A device exactly on a vertex's normal line is exactly at that vertex (a straight push at a
  // node renders that node's normal, bit for bit).
  for (int k = 0; k < 3; ++k) {
    const Vec3 v = mesh::row3(V_, F_(f, k)), nv = mesh::row3(N_, F_(f, k));
    if (w[k] > 1.0 - 1e-9 && (x - v).cross(nv).norm() <= 1e-12 * (1.0 + (x - v).norm()) &&
        (v - x).dot(nv) > 0.0)
      w = Vec3::Unit(k);
  }
  SurfacePoint out;
  out.face = f;
  out.w = w;
  at(f, w, t, out.p, m);
  if (info) {
    info->converged = converged;
    info->capped = capped && !converged;
    info->iterations = it;
    info->residual = (out.p - t * m - x).norm();
    info->travel = travelled;
    info->t = t;
    info->reach = reach_margin(out, t);
  }
  return out;
}

double ContactTracker::reach_margin(const SurfacePoint& s, double t) const {
  // The normal-line map (q, t) -> q - t m(q) at depth t, relative to t = 0, restricted to the
  // tangent plane: M = I - t S (S the shape operator of the shaded normal field on the face).
  // Its eigenvalues are 1 - t kappa_i; the smaller real part is returned (1 at the surface, 0
  // at a focal point, < 0 past it).
  const int f = s.face;
  const Vec3 a = mesh::row3(V_, F_(f, 0)), na = mesh::row3(N_, F_(f, 0));
  Eigen::Matrix<double, 3, 2> A0, At;
  A0.col(0) = mesh::row3(V_, F_(f, 1)) - a;
  A0.col(1) = mesh::row3(V_, F_(f, 2)) - a;
  At.col(0) = A0.col(0) - t * (mesh::row3(N_, F_(f, 1)) - na);
  At.col(1) = A0.col(1) - t * (mesh::row3(N_, F_(f, 2)) - na);
  Vec3 m = Vec3::Zero();
  for (int k = 0; k < 3; ++k) m += s.w[k] * mesh::row3(N_, F_(f, k));
  if (!(m.squaredNorm() > 0)) return -1.0;
  const Eigen::Matrix3d Q = Eigen::Matrix3d::Identity() - m * m.transpose() / m.squaredNorm();
  const Eigen::Matrix<double, 3, 2> B0 = Q * A0, Bt = Q * At;
  const Eigen::Matrix2d G = B0.transpose() * B0;
  if (!(std::abs(G.determinant()) > 0)) return -1.0;
  const Eigen::Matrix2d M = G.inverse() * (B0.transpose() * Bt);
  const double tr = M.trace(), det = M.determinant(), disc = 0.25 * tr * tr - det;
  return disc >= 0 ? 0.5 * tr - std::sqrt(disc) : 0.5 * tr;
}

SurfacePoint ContactTracker::slide(const SurfacePoint& from, const Vec3& delta) const {
  // The part of delta tangential to the shaded normal at `from` (zero for a push along a
  // node's normal: the node is kept), walked along the surface: within a face in its plane, over
  // an edge rotated into the next face's plane, its length kept (the surface unfolded). On a
  // sphere the proxy's position along a straight slide then moves exactly as the device's does.
  int f = from.face;
  Vec3 w = from.w.cwiseMax(0.0);
  w = w.sum() > 0 ? Vec3(w / w.sum()) : Vec3(1.0 / 3, 1.0 / 3, 1.0 / 3);
  const Vec3 n0 = shaded_normal(SurfacePoint{f, w, from.p});
  Vec3 rest = delta - delta.dot(n0) * n0;
  int back_face = -1;
  for (int it = 0; it < 64; ++it) {
    const Vec3 a = mesh::row3(V_, F_(f, 0)), b = mesh::row3(V_, F_(f, 1)),
               c = mesh::row3(V_, F_(f, 2));
    const Vec3 nf = (b - a).cross(c - a);
    const double area2 = nf.squaredNorm();
    if (!(area2 > 0.0)) break;
    const double len = rest.norm();
    rest -= rest.dot(nf) / area2 * nf;  // into the face plane, length kept
    if (!(rest.norm() > 0.0)) break;
    rest *= len / rest.norm();
    // Barycentric change of the in-plane vector `rest`.
    const Vec3 dw(nf.dot(rest.cross(b - c)), nf.dot(rest.cross(c - a)), nf.dot(rest.cross(a - b)));
    const Vec3 dw_unit = dw / area2;
    double amax = 1.0;
    int exit_k = -1;
    for (int k = 0; k < 3; ++k)
      if (dw_unit[k] < 0.0 && w[k] + dw_unit[k] < 0.0 && w[k] / -dw_unit[k] < amax) {
        amax = w[k] / -dw_unit[k];
        exit_k = k;
      }
    w = (w + amax * dw_unit).cwiseMax(0.0);
    w /= w.sum();
    rest *= 1.0 - amax;
    if (exit_k < 0) break;
    const int g = ix_.edge_face[3 * f + exit_k];
    if (g < 0 || (g == back_face && amax == 0.0)) break;
    const Vec3 wg = weights_across(F_, f, g, exit_k, w);
    if (!(wg.sum() > 0)) break;
    back_face = f;
    f = g;
    w = wg / wg.sum();
  }
  SurfacePoint out;
  out.face = f;
  out.w = w;
  out.p = w[0] * mesh::row3(V_, F_(f, 0)) + w[1] * mesh::row3(V_, F_(f, 1)) +
          w[2] * mesh::row3(V_, F_(f, 2));
  return out;
}

Vec3 ContactTracker::shaded_normal(const SurfacePoint& s) const {
  Vec3 n = Vec3::Zero();
  for (int k = 0; k < 3; ++k) n += s.w[k] * mesh::row3(N_, F_(s.face, k));
  const double l = n.norm();
  if (l > 1e-12) return n / l;
  // Opposite vertex normals cancel (a sliver fold): the face's own normal.
  const Vec3 a = mesh::row3(V_, F_(s.face, 0));
  const Vec3 fn = (mesh::row3(V_, F_(s.face, 1)) - a).cross(mesh::row3(V_, F_(s.face, 2)) - a);
  return fn.norm() > 0 ? Vec3(fn.normalized()) : Vec3::UnitZ();
}

void ContactTracker::set_contact(const SurfacePoint& s, const Vec3& x) {
  proxy_ = s;
  n_ = shaded_normal(s);
  depth_ = (s.p - x).dot(n_);
  engaged_ = depth_ > 0.0;
  if (!engaged_) {
    depth_ = 0.0;
    outside_known_ = true;
    node_ = -1;
    return;
  }
  // The node for node-based models: the face vertex of the largest weight, with hysteresis (the
  // last node is kept while it is a vertex of the face within 0.2 of the largest weight), so a
  // contact point running along an edge does not flicker between its two ends.
  int k = 0;
  const double wmax = s.w.maxCoeff(&k);
  int keep = -1;
  for (int m = 0; m < 3; ++m)
    if (F_(s.face, m) == node_ && s.w[m] >= wmax - 0.2) keep = node_;
  node_ = keep >= 0 ? keep : F_(s.face, k);
}

SurfacePoint ContactTracker::projection_near(const SurfacePoint& c, const Vec3& x) const {
  // The Phong projection reached from c (the closest surface point to an x found inside) within
  // the ball of radius |x - c| around it; c itself if there is none within the reach.
  WalkInfo wi;
  const SurfacePoint q = walk(c, x, (x - c.p).norm(), &wi);
  return wi.converged && wi.reach >= kMinReach && (q.p - x).dot(shaded_normal(q)) > 0.0 ? q : c;
}

SurfacePoint ContactTracker::follow(const SurfacePoint& s, const Vec3& from, const Vec3& x,
                                    bool entry) const {
  // Within the reach of the surface (every 1 - t kappa_i >= kMinReach at the projection: the
  // device less deep than 3/4 of the local radius of curvature) the proxy is the Phong
  // projection, which moves it by at most 1 / kMinReach = kGain times the device's tangential
  // motion; the walk's path is bounded by kTrack times the gain at the proxy times that motion,
  // plus kAllow of a mean edge (see kTrack: a proxy off the projection catches up slowly, so the
  // force does not jump). Entering (`entry`: the first step of a contact, no force to jump from)
  // the bound is kGain times the whole motion plus 1 % of an edge. Deeper -- near or past the
  // centre of curvature, where the projection's gain 1 / (1 - t kappa) grows without bound and its
  // solution leaves the side of entry (on a sphere past its centre the entry-side solution moves
  // against the device) -- the proxy follows the device's tangential motion along the surface (a
  // god-object on the local tangent plane, Zilles & Salisbury 1995), and returns to the projection,
  // within the same bound per step, when the device is back within the reach. Before, the walk was
  // refused there and the proxy stayed on its node for good (a 2.5 N slide on C's ovary tip).
  // The projection's gain at the proxy: the device's depth there along the unnormalised shaded
  // normal m, t = (p - x) . m / |m|^2 (as the walk starts), into reach_margin.
  Vec3 m = Vec3::Zero();
  for (int k = 0; k < 3; ++k) m += s.w[k] * mesh::row3(N_, F_(s.face, k));
  const double m2 = m.squaredNorm();
  const Vec3 n = m2 > 0 ? Vec3(m / std::sqrt(m2)) : Vec3::Zero();
  const Vec3 dx = x - from;
  const double tangential = (dx - dx.dot(n) * n).norm();
  const double t0 = m2 > 0 ? (s.p - x).dot(m) / m2 : 0.0;
  const double gain = 1.0 / std::max(reach_margin(s, t0), kMinReach);
  const double cap = entry ? kGain * dx.norm() + kEntryAllow * ix_.mean_edge
                           : kTrack * gain * tangential + kAllow * ix_.mean_edge;
  WalkInfo wi;
  const SurfacePoint q = walk(s, x, cap, &wi);
  if ((wi.converged || wi.capped) && wi.reach >= kMinReach) return q;
  return slide(s, x - from);
}

void ContactTracker::update(const Vec3& from, const Vec3& x) {
  started_inside_ = false;
  if (F_.rows() == 0) return;
  if (engaged_) {
    set_contact(follow(proxy_, from, x), x);
    return;
  }
  if (!outside_known_) {
    // Side unknown: the inside test, then the proxy at the closest surface point.
    if (winding_number(x) > 0.5) {
      set_contact(projection_near(closest_point(x), x), x);
      started_inside_ = engaged_;
      outside_known_ = true;
      return;
    }
    outside_known_ = true;
    return;
  }
  SurfacePoint hit;
  if (!first_entry(from, x, hit)) return;
  SurfacePoint q = follow(hit, hit.p, x, true);
  // A long jump in one step (a device that was parked somewhere and reports a point deep in the
  // organ; a bridge's first datagram) can leave the walk from the entry point on a face whose
  // normal line does not reach the device. The device did enter: if it is inside, the proxy
  // goes to the closest surface point, as for a device found inside.
  if (!((q.p - x).dot(shaded_normal(q)) > 0.0) && winding_number(x) > 0.5)
    q = projection_near(closest_point(x), x);
  set_contact(q, x);
}

}  // namespace palplab::engine
