#include "engine/haptics/contact.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace palplab::engine {

namespace {

using Vec3 = Eigen::Vector3d;

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

ContactTracker::ContactTracker(const mesh::Positions& V, const mesh::Positions& N,
                               const mesh::Faces& F)
    : V_(V), N_(N), F_(F) {
  const long nv = V.rows(), nf = F.rows();
  vf_offset_.assign(nv + 1, 0);
  for (long f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) ++vf_offset_[F(f, k) + 1];
  for (long i = 0; i < nv; ++i) vf_offset_[i + 1] += vf_offset_[i];
  vf_.resize(vf_offset_[nv]);
  std::vector<int> fill(vf_offset_.begin(), vf_offset_.end() - 1);
  for (long f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) vf_[fill[F(f, k)]++] = static_cast<int>(f);
  // Face across each edge: edge_face_[3 f + k] is the face sharing the edge opposite corner k.
  edge_face_.assign(3 * nf, -1);
  for (long f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const int u = F(f, (k + 1) % 3), v = F(f, (k + 2) % 3);
      for (int j = vf_offset_[u]; j < vf_offset_[u + 1] && edge_face_[3 * f + k] < 0; ++j) {
        const int g = vf_[j];
        if (g == f) continue;
        for (int m = 0; m < 3; ++m)
          if (F(g, m) == v) edge_face_[3 * f + k] = g;
      }
    }
  double edges = 0.0;
  for (long f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k)
      edges += (mesh::row3(V, F(f, k)) - mesh::row3(V, F(f, (k + 1) % 3))).norm();
  mean_edge_ = nf > 0 ? edges / (3.0 * nf) : 0.0;
  face_box_.resize(nf);
  for (long f = 0; f < nf; ++f) {
    face_box_[f].setEmpty();
    for (int k = 0; k < 3; ++k) face_box_[f].extend(mesh::row3(V, F(f, k)));
  }
  order_.resize(nf);
  std::iota(order_.begin(), order_.end(), 0);
  bvh_.reserve(2 * nf / 4 + 2);
  if (nf > 0) build(0, static_cast<int>(nf));
  stack_.reserve(64);
}

// Top-down median split on the longest axis of the face boxes' centres; leaves of <= 4 faces.
int ContactTracker::build(int begin, int end) {
  const int id = static_cast<int>(bvh_.size());
  bvh_.push_back({});
  Eigen::AlignedBox3d box, centres;
  box.setEmpty();
  centres.setEmpty();
  for (int k = begin; k < end; ++k) {
    box.extend(face_box_[order_[k]]);
    centres.extend(face_box_[order_[k]].center());
  }
  bvh_[id].box = box;
  bvh_[id].begin = begin;
  bvh_[id].end = end;
  if (end - begin > 4) {
    int axis = 0;
    centres.sizes().maxCoeff(&axis);
    const int mid = (begin + end) / 2;
    std::nth_element(
        order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
        [&](int a, int b) { return face_box_[a].center()[axis] < face_box_[b].center()[axis]; });
    const int l = build(begin, mid);
    const int r = build(mid, end);
    bvh_[id].left = l;
    bvh_[id].right = r;
  }
  return id;
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
    if (face_box_[f].squaredExteriorDistance(x) >= bd) continue;
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
  if (bvh_.empty()) return false;
  const Vec3 d = b - a;
  Eigen::AlignedBox3d seg(a.cwiseMin(b), a.cwiseMax(b));
  const double pad = 1e-12 * (1.0 + a.cwiseAbs().maxCoeff() + b.cwiseAbs().maxCoeff());
  seg.min().array() -= pad;
  seg.max().array() += pad;
  double best_t = INFINITY;
  stack_.clear();
  stack_.push_back(0);
  while (!stack_.empty()) {
    const BvhNode& nd = bvh_[stack_.back()];
    stack_.pop_back();
    if (!nd.box.intersects(seg)) continue;
    if (nd.left >= 0) {
      stack_.push_back(nd.left);
      stack_.push_back(nd.right);
      continue;
    }
    for (int k = nd.begin; k < nd.end; ++k) {
      const int f = order_[k];
      if (!face_box_[f].intersects(seg)) continue;
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
  // Phong projection: the proxy p on the surface whose shaded normal passes through x,
  // x = p - d n(p). Under a straight push along a node's normal the proxy stays on the node (a
  // deformable tissue keeps its contact node); sliding moves it continuously, since n is
  // continuous over edges. Per face a few fixed-point steps (n from the current weights, x
  // projected onto the face plane along n); a weight below 0 walks to the face across that edge.
  int f = from.face, prev = -1;
  Vec3 w = from.w;
  Vec3 p = from.p;
  for (int it = 0; it < 64; ++it) {
    const Vec3 a = mesh::row3(V_, F_(f, 0)), b = mesh::row3(V_, F_(f, 1)),
               c = mesh::row3(V_, F_(f, 2));
    const Vec3 nf = (b - a).cross(c - a);
    const double area2 = nf.squaredNorm();
    if (!(area2 > 0.0)) break;  // degenerate face: keep the last point
    Vec3 wu = w;
    for (int j = 0; j < 16; ++j) {  // converges linearly, fast for d |dn/dp| < 1
      SurfacePoint q{f, wu.cwiseMax(0.0) / std::max(wu.cwiseMax(0.0).sum(), 1e-300), p};
      const Vec3 n = shaded_normal(q);
      const double den = n.dot(nf);
      if (!(std::abs(den) > 1e-3 * std::sqrt(area2))) break;  // n nearly in the face plane
      p = x + ((a - x).dot(nf) / den) * n;
      const Vec3 w_old = wu;
      wu = Vec3((b - p).cross(c - p).dot(nf), (c - p).cross(a - p).dot(nf),
                (a - p).cross(b - p).dot(nf)) /
           area2;
      if ((wu - w_old).cwiseAbs().maxCoeff() < 1e-14) break;
    }
    int k = 0;
    const double wmin = wu.minCoeff(&k);
    if (wmin >= -1e-12) {
      w = wu.cwiseMax(0.0) / wu.cwiseMax(0.0).sum();
      break;
    }
    const int g = edge_face_[3 * f + k];
    if (g < 0 || g == prev) {  // a boundary, or back and forth over one edge: stay on the edge
      w = wu.cwiseMax(0.0);
      w = w.sum() > 0 ? Vec3(w / w.sum()) : Vec3(1.0 / 3, 1.0 / 3, 1.0 / 3);
      break;
    }
    // Weights of the same point in the neighbour (a starting guess for its fixed point).
    prev = f;
    f = g;
    const Vec3 a2 = mesh::row3(V_, F_(f, 0)), b2 = mesh::row3(V_, F_(f, 1)),
               c2 = mesh::row3(V_, F_(f, 2));
    const Vec3 n2 = (b2 - a2).cross(c2 - a2);
    const double ar2 = std::max(n2.squaredNorm(), 1e-300);
    w = Vec3((b2 - p).cross(c2 - p).dot(n2), (c2 - p).cross(a2 - p).dot(n2),
             (a2 - p).cross(b2 - p).dot(n2)) /
        ar2;
    w = w.cwiseMax(0.0);
    w = w.sum() > 0 ? Vec3(w / w.sum()) : Vec3(1.0 / 3, 1.0 / 3, 1.0 / 3);
  }
  // A device exactly on a vertex's normal line is exactly at that vertex (the fixed point only
  // approaches it linearly; a straight push at a node must render that node's normal).
  for (int k = 0; k < 3; ++k) {
    const Vec3 v = mesh::row3(V_, F_(f, k)), nv = mesh::row3(N_, F_(f, k));
    if ((x - v).cross(nv).norm() <= 1e-12 * (1.0 + (x - v).norm()) && (v - x).dot(nv) > 0.0)
      w = Vec3::Unit(k);
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

void ContactTracker::update(const Vec3& from, const Vec3& x) {
  started_inside_ = false;
  if (F_.rows() == 0) return;
  if (engaged_) {
    // Near a focal point of the surface (deeper than its local radius of curvature, e.g. past
    // the middle of a small ovary whose soft tissue lets the hand that deep) the projection is
    // no longer unique and the walk may run off. The proxy then stays where it is, on the side
    // of entry: when the walk ends on the outside while the device is still below the old
    // proxy, or moves more than 4 times the device's step plus a tenth of a mean edge (sliding
    // at a few mm depth moves it about 1.2 times the device's step). A device that holds still
    // lets the walk finish converging (e.g. after a jump onto a node's normal line).
    const SurfacePoint q = walk(proxy_, x);
    const double d_new = (q.p - x).dot(shaded_normal(q)), d_old = (proxy_.p - x).dot(n_);
    const double moved = (x - from).norm();
    const bool run_off = moved > 0.0 && ((d_new <= 0.0 && d_old > 0.0) ||
                                         (q.p - proxy_.p).norm() > 4.0 * moved + 0.1 * mean_edge_);
    set_contact(run_off ? proxy_ : q, x);
    return;
  }
  if (!outside_known_) {
    // Side unknown: the inside test, then the proxy at the closest surface point.
    if (winding_number(x) > 0.5) {
      set_contact(closest_point(x), x);
      started_inside_ = engaged_;
      outside_known_ = true;
      return;
    }
    outside_known_ = true;
    return;
  }
  SurfacePoint hit;
  if (!first_entry(from, x, hit)) return;
  SurfacePoint q = walk(hit, x);
  // A long jump in one step (a device that was parked somewhere and reports a point deep in the
  // organ; a bridge's first datagram) can leave the walk from the entry point on a face whose
  // normal line does not reach the device. The device did enter: if it is inside, the proxy
  // goes to the closest surface point, as for a device found inside.
  if (!((q.p - x).dot(shaded_normal(q)) > 0.0) && winding_number(x) > 0.5) q = closest_point(x);
  set_contact(q, x);
}

}  // namespace palplab::engine
