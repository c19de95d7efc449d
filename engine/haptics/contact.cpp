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
  proxy_ = SurfacePoint{};
  depth_ = 0.0;
}

void ContactTracker::invalidate() {
  reset();
}

int ContactTracker::node() const {
  if (!engaged_) return -1;
  int k = 0;
  proxy_.w.maxCoeff(&k);
  return F_(proxy_.face, k);
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
  SurfacePoint cur = closest_on_face(from.face, x);
  double cd = (cur.p - x).squaredNorm();
  // Each move is to a face sharing a vertex with the current one and strictly closer, so the
  // walk ends; the cap only bounds the work of a step (a long jump continues next step).
  for (int it = 0; it < 64; ++it) {
    if (cur.w.minCoeff() > 0.0) break;  // x projects inside the face: the proxy stays
    SurfacePoint best = cur;
    double bd = cd * (1.0 - 1e-12);
    for (int k = 0; k < 3; ++k) {
      if (cur.w[k] == 0.0) continue;  // only faces around the boundary part the point is on
      const int v = F_(cur.face, k);
      for (int j = vf_offset_[v]; j < vf_offset_[v + 1]; ++j) {
        const int g = vf_[j];
        if (g == cur.face) continue;
        // The face must contain the closest point's support (its edge or vertex).
        bool shares = true;
        for (int m = 0; m < 3; ++m)
          if (cur.w[m] > 0.0) {
            const int u = F_(cur.face, m);
            shares = shares && (F_(g, 0) == u || F_(g, 1) == u || F_(g, 2) == u);
          }
        if (!shares) continue;
        const SurfacePoint s = closest_on_face(g, x);
        const double d = (s.p - x).squaredNorm();
        if (d < bd) {
          bd = d;
          best = s;
        }
      }
    }
    if (best.face == cur.face) break;
    cur = best;
    cd = (cur.p - x).squaredNorm();
  }
  return cur;
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
  }
}

void ContactTracker::update(const Vec3& from, const Vec3& x) {
  started_inside_ = false;
  if (F_.rows() == 0) return;
  if (engaged_) {
    set_contact(walk(proxy_, x), x);
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
  if (first_entry(from, x, hit)) set_contact(walk(hit, x), x);
}

}  // namespace palplab::engine
