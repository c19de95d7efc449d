#include "engine/models/needle.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <stdexcept>

#include "common/input_error.hpp"
#include "results/sha256.hpp"

namespace palplab::engine {

namespace {

// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5).
Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double den = 1 / (va + vb + vc);
  return a + ab * (vb * den) + ac * (vc * den);
}

// Ray origin + t dir against triangle abc (Moeller-Trumbore, both sides); edges count with a
// small relative tolerance so that a ray through a shared edge is not lost between two faces.
bool ray_triangle(const Vec3& o, const Vec3& d, const Vec3& a, const Vec3& b, const Vec3& c,
                  double* t) {
  const Vec3 e1 = b - a, e2 = c - a, p = d.cross(e2);
  const double det = e1.dot(p);
  if (std::abs(det) < 1e-300) return false;
  const double inv = 1 / det;
  const Vec3 s = o - a;
  const double u = s.dot(p) * inv;
  constexpr double eps = 1e-9;
  if (u < -eps || u > 1 + eps) return false;
  const Vec3 q = s.cross(e1);
  const double v = d.dot(q) * inv;
  if (v < -eps || u + v > 1 + eps) return false;
  *t = e2.dot(q) * inv;
  return true;
}

}  // namespace

const char* to_string(NeedleEvent::Kind k) {
  switch (k) {
    case NeedleEvent::Kind::tissue_entered:
      return "tissue_entered";
    case NeedleEvent::Kind::tissue_left:
      return "tissue_left";
    case NeedleEvent::Kind::bone_contact:
      return "bone_contact";
    case NeedleEvent::Kind::target_reached:
      return "target_reached";
  }
  return "?";
}

NeedleModel::NeedleModel(const mesh::TetMesh& m, const mesh::MaterialTable& materials,
                         const NeedleOptions& opt)
    : NeedleModel(m.V, m.T, m.attribute, materials, opt) {}

NeedleModel::NeedleModel(const mesh::Positions& V, const mesh::Tets& T,
                         const Eigen::VectorXi& attribute, const mesh::MaterialTable& materials,
                         const NeedleOptions& opt, std::string_view precomputed)
    : V_(V), T_(T), A_(attribute), opt_(opt) {
  check_tissues(materials);
  restored_ = !precomputed.empty() && restore(precomputed);
  if (!restored_) precompute();
}

void NeedleModel::check_tissues(const mesh::MaterialTable& materials) {
  const int nt = static_cast<int>(T_.rows());
  if (nt == 0) throw InputError("needle: the mesh has no tetrahedra");
  if (A_.size() != nt) A_ = Eigen::VectorXi::Zero(nt);
  // Tissues present.
  std::map<int, int> seen;
  for (int t = 0; t < nt; ++t) seen.emplace(A_[t], 0);
  if (!seen.count(opt_.target_tissue))
    throw InputError("needle: the mesh has no tet of the target tissue " +
                     std::to_string(opt_.target_tissue));
  for (auto& [a, unused] : seen) {
    const mesh::Material* mat = materials.find(a);
    if (!mat) throw InputError("needle: no material covers tissue attribute " + std::to_string(a));
    if (!mat->needle.defined)
      throw InputError("needle: material \"" + mat->name + "\" (tissue " + std::to_string(a) +
                       ") has no \"needle\" parameters");
    tissues_.push_back({a, mat->name, mat->rigid, mat->needle});
  }
  for (long i = 0; i < T_.size(); ++i)
    if (T_.data()[i] < 0 || T_.data()[i] >= V_.rows())
      throw InputError("needle: a tet refers to a missing node");
}

void NeedleModel::precompute() {
  const int nt = static_cast<int>(T_.rows());
  // Interfaces and the target's surface.
  const mesh::Tets N = mesh::tet_neighbours(mesh::make_tet_mesh(V_, T_, A_));
  auto tri = [&](int t, int k) {
    const int* f = mesh::kTetFace[k];
    return Tri{mesh::row3(V_, T_(t, f[0])), mesh::row3(V_, T_(t, f[1])),
               mesh::row3(V_, T_(t, f[2]))};
  };
  for (int t = 0; t < nt; ++t)
    for (int k = 0; k < 4; ++k) {
      const int nb = N(t, k);
      if (nb < 0 || (A_[nb] != A_[t] && t < nb)) interfaces_.push_back(tri(t, k));
      if (A_[t] == opt_.target_tissue && (nb < 0 || A_[nb] != opt_.target_tissue))
        target_faces_.push_back(tri(t, k));
      if (nb < 0 || A_[nb] != A_[t]) {
        const int* f = mesh::kTetFace[k];
        tissue_faces_.push_back({A_[t], {T_(t, f[0]), T_(t, f[1]), T_(t, f[2])}});
      }
    }
  // Point-location grid: about two tets per cell.
  lo_ = V_.colwise().minCoeff().transpose();
  const Vec3 hi = V_.colwise().maxCoeff().transpose();
  const Vec3 ext = (hi - lo_).cwiseMax(1e-12);
  const double h = std::cbrt(ext.prod() / std::max(1.0, nt / 2.0));
  nx_ = std::clamp(static_cast<int>(std::ceil(ext.x() / h)), 1, 256);
  ny_ = std::clamp(static_cast<int>(std::ceil(ext.y() / h)), 1, 256);
  nz_ = std::clamp(static_cast<int>(std::ceil(ext.z() / h)), 1, 256);
  cell_ = Vec3(ext.x() / nx_, ext.y() / ny_, ext.z() / nz_);
  auto range = [&](int t, int lo[3], int hi3[3]) {
    Vec3 a = mesh::row3(V_, T_(t, 0)), b = a;
    for (int k = 1; k < 4; ++k) {
      a = a.cwiseMin(mesh::row3(V_, T_(t, k)));
      b = b.cwiseMax(mesh::row3(V_, T_(t, k)));
    }
    const int n[3] = {nx_, ny_, nz_};
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::clamp(static_cast<int>(std::floor((a[d] - lo_[d]) / cell_[d])), 0, n[d] - 1);
      hi3[d] = std::clamp(static_cast<int>(std::floor((b[d] - lo_[d]) / cell_[d])), 0, n[d] - 1);
    }
  };
  const int ncell = nx_ * ny_ * nz_;
  std::vector<int> count(ncell + 1, 0);
  for (int pass = 0; pass < 2; ++pass) {
    for (int t = 0; t < nt; ++t) {
      int a[3], b[3];
      range(t, a, b);
      for (int z = a[2]; z <= b[2]; ++z)
        for (int y = a[1]; y <= b[1]; ++y)
          for (int x = a[0]; x <= b[0]; ++x) {
            const int c = x + nx_ * (y + ny_ * z);
            if (pass == 0)
              ++count[c + 1];
            else
              grid_.index[count[c]++] = t;
          }
    }
    if (pass == 0) {
      for (int c = 0; c < ncell; ++c) count[c + 1] += count[c];
      grid_.offset = count;
      grid_.index.resize(count[ncell]);
    }
  }
}

namespace {

constexpr char kBlobTag[8] = {'N', 'E', 'E', 'D', 'L', 'E', 'P', '1'};

struct BlobIn {
  std::string_view b;
  std::size_t at = 0;
  bool ok = true;
  void raw(void* p, std::size_t n) {
    if (!ok || b.size() - at < n) {
      ok = false;
      return;
    }
    std::memcpy(p, b.data() + at, n);
    at += n;
  }
  template <class T>
  T get() {
    T v{};
    raw(&v, sizeof v);
    return v;
  }
  // A counted array of T, at most `limit` elements.
  template <class T>
  std::vector<T> vec(std::uint64_t limit) {
    const auto n = get<std::uint64_t>();
    if (!ok || n > limit || n > (b.size() - at) / sizeof(T)) {
      ok = false;
      return {};
    }
    std::vector<T> v(n);
    raw(v.data(), n * sizeof(T));
    return v;
  }
};

template <class T>
void put(std::string& s, const T& v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof v);
}
template <class T>
void put_vec(std::string& s, const std::vector<T>& v) {
  put<std::uint64_t>(s, v.size());
  s.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

}  // namespace

std::array<std::uint8_t, 32> NeedleModel::inputs_digest() const {
  results::Sha256 h;
  auto add = [&](const void* p, std::size_t n) {
    const std::uint64_t len = n;
    h.update(&len, sizeof len);  // lengths keep the fields apart
    h.update(p, n);
  };
  add(V_.data(), sizeof(double) * V_.size());
  add(T_.data(), sizeof(int) * T_.size());
  add(A_.data(), sizeof(int) * A_.size());
  add(&opt_.target_tissue, sizeof opt_.target_tissue);
  return h.digest();
}

std::string NeedleModel::save() const {
  static_assert(sizeof(Tri) == 9 * sizeof(double));
  std::string s(kBlobTag, 8);
  const auto d = inputs_digest();
  s.append(reinterpret_cast<const char*>(d.data()), d.size());
  put_vec(s, interfaces_);
  put_vec(s, target_faces_);
  put(s, lo_);
  put(s, cell_);
  put(s, nx_);
  put(s, ny_);
  put(s, nz_);
  put_vec(s, grid_.offset);
  put_vec(s, grid_.index);
  put_vec(s, tissue_faces_);
  return s;
}

bool NeedleModel::restore(std::string_view blob) {
  if (blob.size() < 40 || std::memcmp(blob.data(), kBlobTag, 8) != 0) return false;
  const auto d = inputs_digest();
  if (std::memcmp(blob.data() + 8, d.data(), d.size()) != 0) return false;
  BlobIn in{blob, 40};
  const std::uint64_t faces = 4 * static_cast<std::uint64_t>(T_.rows());
  auto interfaces = in.vec<Tri>(faces);
  auto target = in.vec<Tri>(faces);
  const auto lo = in.get<Vec3>(), cell = in.get<Vec3>();
  const int nx = in.get<int>(), ny = in.get<int>(), nz = in.get<int>();
  if (!in.ok || nx < 1 || ny < 1 || nz < 1 || nx > 256 || ny > 256 || nz > 256) return false;
  mesh::Csr grid;
  const std::uint64_t cells = static_cast<std::uint64_t>(nx) * ny * nz;
  grid.offset = in.vec<int>(cells + 1);
  grid.index = in.vec<int>(std::numeric_limits<std::uint32_t>::max());
  auto tissue_faces = in.vec<TissueFace>(faces);
  for (const TissueFace& f : tissue_faces)
    for (int v : f.v)
      if (v < 0 || v >= V_.rows()) return false;
  if (!in.ok || in.at != blob.size() || grid.offset.size() != cells + 1 || grid.offset[0] != 0 ||
      grid.offset.back() != static_cast<int>(grid.index.size()))
    return false;
  for (std::size_t c = 0; c + 1 < grid.offset.size(); ++c)
    if (grid.offset[c + 1] < grid.offset[c]) return false;
  for (int t : grid.index)
    if (t < 0 || t >= T_.rows()) return false;
  interfaces_ = std::move(interfaces);
  target_faces_ = std::move(target);
  lo_ = lo;
  cell_ = cell;
  nx_ = nx;
  ny_ = ny;
  nz_ = nz;
  grid_ = std::move(grid);
  tissue_faces_ = std::move(tissue_faces);
  return true;
}

const NeedleTissue& NeedleModel::tissue(int attribute) const {
  for (const NeedleTissue& t : tissues_)
    if (t.attribute == attribute) return t;
  throw std::out_of_range("needle: no tissue " + std::to_string(attribute));
}

int NeedleModel::tissue_at(const Vec3& p) const {
  int c[3];
  const int n[3] = {nx_, ny_, nz_};
  for (int d = 0; d < 3; ++d) {
    const double x = (p[d] - lo_[d]) / cell_[d];
    if (!(x >= -1e-9 && x <= n[d] + 1e-9)) return -1;
    c[d] = std::clamp(static_cast<int>(std::floor(x)), 0, n[d] - 1);
  }
  for (int t : grid_.row(c[0] + nx_ * (c[1] + ny_ * c[2]))) {
    const Vec3 a = mesh::row3(V_, T_(t, 0));
    Eigen::Matrix3d M;
    M.col(0) = mesh::row3(V_, T_(t, 1)) - a;
    M.col(1) = mesh::row3(V_, T_(t, 2)) - a;
    M.col(2) = mesh::row3(V_, T_(t, 3)) - a;
    const Vec3 l = M.partialPivLu().solve(p - a);
    constexpr double eps = 1e-10;
    if (l.minCoeff() >= -eps && l.sum() <= 1 + eps) return A_[t];
  }
  return -1;
}

double NeedleModel::distance_to_target(const Vec3& p) const {
  if (tissue_at(p) == opt_.target_tissue) return 0;
  double best = std::numeric_limits<double>::infinity();
  for (const Tri& f : target_faces_)
    best = std::min(best, (closest_on_triangle(p, f.a, f.b, f.c) - p).squaredNorm());
  return std::sqrt(best);
}

std::vector<NeedleLayer> NeedleModel::layers_along(const Vec3& origin, const Vec3& dir_in) const {
  const Vec3 dir = dir_in.normalized();
  std::vector<double> ts;
  for (const Tri& f : interfaces_) {
    double t;
    if (ray_triangle(origin, dir, f.a, f.b, f.c, &t) && t >= 0) ts.push_back(t);
  }
  std::sort(ts.begin(), ts.end());
  const double scale = (V_.colwise().maxCoeff() - V_.colwise().minCoeff()).norm();
  std::vector<double> u;
  for (double t : ts)
    if (u.empty() || t - u.back() > 1e-9 * scale) u.push_back(t);
  std::vector<NeedleLayer> out;
  auto push = [&](double a, double b, int tissue) {
    if (!out.empty() && out.back().tissue == tissue)
      out.back().exit = b;
    else
      out.push_back({a, b, tissue});
  };
  double prev = 0;
  for (size_t i = 0; i <= u.size(); ++i) {
    const double next = i < u.size() ? u[i] : std::numeric_limits<double>::infinity();
    // The tissue of [prev, next): probe its middle (beyond the last crossing: outside).
    const int tissue = i < u.size() ? tissue_at(origin + (prev + next) / 2 * dir) : -1;
    if (next > prev) push(prev, next, tissue);
    prev = next;
  }
  return out;
}

void NeedleModel::reset() {
  inserted_ = false;
  bounds_.clear();
  beyond_.clear();
  punctured_ = 0;
  interval_ = -1;
  s_prev_ = deepest_ = 0;
  bone_pressing_ = target_reached_ = false;
  entered_.clear();
}

NeedleStep NeedleModel::step(const Vec3& tip, const Vec3& axis_in) {
  if (!(axis_in.norm() > 0) || !axis_in.allFinite() || !tip.allFinite())
    throw std::invalid_argument("needle: tip and axis must be finite and the axis non-zero");
  NeedleStep out;
  out.tip = tip;
  out.tissue = -1;
  if (!inserted_) {
    // Contact when the tip has passed the body's surface along its own axis.
    const Vec3 a = axis_in.normalized();
    const Vec3 centre = (V_.colwise().maxCoeff() + V_.colwise().minCoeff()).transpose() / 2;
    const double far =
        (V_.colwise().maxCoeff() - V_.colwise().minCoeff()).norm() + (tip - centre).norm() + 1e-3;
    const Vec3 o = tip - far * a;
    const std::vector<NeedleLayer> layers = layers_along(o, a);
    size_t first = 0;
    while (first < layers.size() && layers[first].tissue < 0) ++first;
    if (first == layers.size() || far - layers[first].enter <= 0) {
      out.tip_to_target = distance_to_target(tip);
      return out;
    }
    const double t0 = layers[first].enter;
    reset();
    inserted_ = true;
    ++insertions_;
    entry_ = o + t0 * a;
    axis_ = a;
    for (size_t i = first; i < layers.size(); ++i) {
      bounds_.push_back(layers[i].enter - t0);
      beyond_.push_back(layers[i].tissue);
    }
  }
  const double s = (tip - entry_).dot(axis_);
  out.inserted = true;
  out.depth = s;
  out.lateral_offset = ((tip - entry_) - s * axis_).norm();
  auto tissue_of = [&](int iv) { return iv < 0 ? -1 : beyond_[iv]; };
  auto event = [&](NeedleEvent::Kind k, int tissue, double depth) {
    NeedleEvent e;
    e.kind = k;
    e.tissue = tissue;
    e.name = tissue >= 0 ? this->tissue(tissue).name : "";
    e.depth = depth;
    e.position = entry_ + depth * axis_;
    out.events.push_back(std::move(e));
  };

  // Puncture: pass every interface the tip pushes through with at least its threshold force.
  const int n = static_cast<int>(bounds_.size());
  bool bone = false;
  int bone_tissue = -1;
  while (punctured_ < n && s > bounds_[punctured_]) {
    const int t = beyond_[punctured_];
    if (t < 0) {  // leaving the body: nothing to puncture
      ++punctured_;
      continue;
    }
    const NeedleTissue& tt = tissue(t);
    const double f = tt.params.puncture_stiffness * (s - bounds_[punctured_]);
    if (!tt.rigid && f >= tt.params.puncture_force) {
      ++punctured_;
      continue;
    }
    out.tip_force = f;
    bone = tt.rigid;
    bone_tissue = t;
    break;
  }
  const bool pressing = out.tip_force > 0;
  const double d_tip = pressing ? bounds_[punctured_] : std::max(0.0, s);

  // Interval of the tip and the crossings since the last step.
  int iv = -1;
  for (int k = 0; k < punctured_; ++k)
    if (bounds_[k] < d_tip) iv = k;
  if (s < 0) iv = -1;
  while (interval_ < iv) {
    if (tissue_of(interval_) >= 0)
      event(NeedleEvent::Kind::tissue_left, tissue_of(interval_), bounds_[interval_ + 1]);
    ++interval_;
    const int t = tissue_of(interval_);
    if (t >= 0) {
      event(NeedleEvent::Kind::tissue_entered, t, bounds_[interval_]);
      entered_.push_back(t);
      if (t == opt_.target_tissue && !target_reached_) {
        target_reached_ = true;
        event(NeedleEvent::Kind::target_reached, t, bounds_[interval_]);
      }
    }
  }
  while (interval_ > iv) {
    if (tissue_of(interval_) >= 0)
      event(NeedleEvent::Kind::tissue_left, tissue_of(interval_), bounds_[interval_]);
    --interval_;
    if (tissue_of(interval_) >= 0)
      event(NeedleEvent::Kind::tissue_entered, tissue_of(interval_), bounds_[interval_ + 1]);
  }
  if (bone && !bone_pressing_) {
    ++bone_contacts_;
    event(NeedleEvent::Kind::bone_contact, bone_tissue, bounds_[punctured_]);
  }
  bone_pressing_ = bone;

  // Cutting and shaft friction.
  const double v = s - s_prev_;
  const int tip_tissue = tissue_of(iv);
  if (v > opt_.rest_tolerance && !pressing && tip_tissue >= 0 && d_tip > deepest_)
    out.cutting_force = tissue(tip_tissue).params.cutting_force;
  if (std::abs(v) > opt_.rest_tolerance) {
    double fr = 0;
    for (int k = 0; k <= iv; ++k) {
      if (beyond_[k] < 0) continue;
      const double hi = k + 1 < n ? std::min(bounds_[k + 1], d_tip) : d_tip;
      if (hi > bounds_[k]) fr += (hi - bounds_[k]) * tissue(beyond_[k]).params.friction;
    }
    out.friction_force = v > 0 ? fr : -fr;
  }
  deepest_ = std::max(deepest_, d_tip);
  s_prev_ = s;

  out.tip_depth = d_tip;
  out.tip = entry_ + d_tip * axis_;
  out.tissue = tip_tissue;
  out.axial_force = out.tip_force + out.cutting_force + out.friction_force;
  out.force = -out.axial_force * axis_;
  out.tip_to_target = distance_to_target(out.tip);
  if (s < 0) {  // pulled out: the insertion is over
    out.tip = tip;
    out.tip_to_target = distance_to_target(tip);
    inserted_ = false;
    out.inserted = false;
  }
  return out;
}

}  // namespace palplab::engine
