#include "engine/mesh/generate.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <string>

#include "common/input_error.hpp"
#include "common/seed.hpp"

namespace palplab::mesh {

namespace {

double smoothstep(double a, double b, double x) {
  const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

// Uniform in [-1, 1] from a derived seed; platform-independent (no std distributions).
double jitter(std::uint64_t seed, const char* label) {
  if (seed == 0) return 0.0;
  const std::uint64_t x = splitmix64(derive_seed(seed, label));
  return 2.0 * (static_cast<double>(x >> 11) * 0x1.0p-53) - 1.0;
}

struct TractShape {
  double z_cervix_end = 0.09, z_body_start = 0.12, z_region_split = 0.10, zj = 0.20;
  double r_cervix = 0.019, r_body = 0.025;
  double xs = 0.0125, tilt = 10 * std::numbers::pi / 180, straight = 0.12,
         yaw = 45 * std::numbers::pi / 180;
  double Rx = 0.027, Rz = 0.025, shrink = 0.2, alpha_end = 1.2 * std::numbers::pi;
  double r_horn_start = 0.0115, r_horn = 0.0095, r_ovary = 0.0135;
  double u_ovary = 0.82;
};

double trunk_radius(const TractShape& s, double z) {
  double r = s.r_cervix + (s.r_body - s.r_cervix) * smoothstep(s.z_cervix_end, s.z_body_start, z);
  const double cap = s.r_cervix;  // rounded (hemispherical) cervix end
  if (z < cap) r *= std::sqrt(std::max(0.0, 1 - (1 - z / cap) * (1 - z / cap)));
  return r;
}

double horn_radius(const TractShape& s, double u) {
  const double taper = s.r_horn_start + (s.r_horn - s.r_horn_start) * smoothstep(0, 0.2, u);
  const double neck = taper * (1 - smoothstep(s.u_ovary - 0.04, s.u_ovary + 0.04, u));
  const double a = (1 - s.u_ovary) / 2 + 0.0, uc = 1 - a;
  const double t = (u - uc) / a;
  const double ov = t * t < 1 ? s.r_ovary * std::sqrt(1 - t * t) : 0.0;
  return std::max(neck, ov);
}

// A curve sampled densely: arc length, position, unit tangent.
struct Curve {
  std::vector<double> s;
  std::vector<Vec3> p, t;
  double length() const { return s.back(); }
  // Index i with s[i] <= x <= s[i+1] and the fraction.
  std::pair<int, double> locate(double x) const {
    auto it = std::upper_bound(s.begin(), s.end(), x);
    int i = std::clamp(static_cast<int>(it - s.begin()) - 1, 0, static_cast<int>(s.size()) - 2);
    double f = (x - s[i]) / std::max(1e-300, s[i + 1] - s[i]);
    return {i, std::clamp(f, 0.0, 1.0)};
  }
  Vec3 pos(double x) const {
    auto [i, f] = locate(x);
    return (1 - f) * p[i] + f * p[i + 1];
  }
  Vec3 tangent(double x) const {
    auto [i, f] = locate(x);
    return ((1 - f) * t[i] + f * t[i + 1]).normalized();
  }
};

// Left horn centreline, in the vertical plane through z and the direction H, which points
// outwards (-x) turned forwards (+y) by the yaw angle: a straight rise tilted towards H, then an
// elliptic spiral curling outwards, forwards and down, the tip pointing back towards the rise.
Vec3 horn_heading(const TractShape& sh) {
  return Vec3(-std::cos(sh.yaw), std::sin(sh.yaw), 0);
}

Curve left_horn_curve(const TractShape& sh) {
  Curve c;
  const Vec3 H = horn_heading(sh), Z(0, 0, 1);
  const Vec3 p0(-sh.xs, 0, sh.zj);
  const Vec3 dir = std::sin(sh.tilt) * H + std::cos(sh.tilt) * Z;
  const int ns = 400, na = 1600;
  for (int i = 0; i < ns; ++i) c.p.push_back(p0 + dir * (sh.straight * i / ns));
  const Vec3 p1 = p0 + dir * sh.straight;
  const Vec3 centre = p1 + sh.Rx * H;
  for (int i = 0; i <= na; ++i) {
    const double a = sh.alpha_end * i / na;
    const double rho = 1 - sh.shrink * a / sh.alpha_end;
    c.p.push_back(centre - sh.Rx * rho * std::cos(a) * H + sh.Rz * rho * std::sin(a) * Z);
  }
  const int n = static_cast<int>(c.p.size());
  c.s.assign(n, 0);
  for (int i = 1; i < n; ++i) c.s[i] = c.s[i - 1] + (c.p[i] - c.p[i - 1]).norm();
  // Tangents averaged over +-8 mm of arc: smooths the kink where the rise meets the spiral.
  std::vector<Vec3> raw(n);
  for (int i = 0; i < n; ++i)
    raw[i] = (c.p[std::min(i + 1, n - 1)] - c.p[std::max(i - 1, 0)]).normalized();
  c.t.resize(n);
  const double w = 0.008;
  for (int i = 0, lo = 0, hi = 0; i < n; ++i) {
    while (c.s[lo] < c.s[i] - w) ++lo;
    while (hi + 1 < n && c.s[hi + 1] <= c.s[i] + w) ++hi;
    Vec3 sum = Vec3::Zero();
    for (int k = lo; k <= hi; ++k) sum += raw[k];
    c.t[i] = sum.normalized();
  }
  return c;
}

// Positions along a meridian profile r(x), x in [0, L], at n equal steps of meridian length
// sqrt(dx^2 + dr^2) (so caps get rings as dense as the sides). Returns n+1 parameters x_0=0..L.
template <class R>
std::vector<double> meridian_stations(double L, R radius, int n) {
  const int m = 4000;
  std::vector<double> xs(m + 1), ms(m + 1, 0);
  for (int i = 0; i <= m; ++i) xs[i] = L * i / m;
  for (int i = 1; i <= m; ++i)
    ms[i] = ms[i - 1] + std::hypot(xs[i] - xs[i - 1], radius(xs[i]) - radius(xs[i - 1]));
  std::vector<double> out(n + 1);
  for (int j = 0; j <= n; ++j) {
    const double target = ms[m] * j / n;
    auto it = std::lower_bound(ms.begin(), ms.end(), target);
    int i = std::clamp(static_cast<int>(it - ms.begin()), 1, m);
    const double f = (target - ms[i - 1]) / std::max(1e-300, ms[i] - ms[i - 1]);
    out[j] = xs[i - 1] + std::clamp(f, 0.0, 1.0) * (xs[i] - xs[i - 1]);
  }
  out[0] = 0;
  out[n] = L;
  return out;
}

template <class R>
double meridian_length(double L, R radius) {
  const int m = 4000;
  double len = 0;
  for (int i = 1; i <= m; ++i)
    len += std::hypot(L / m, radius(L * i / m) - radius(L * (i - 1) / m));
  return len;
}

// Band of triangles between two rings of equal size, both counter-clockwise seen from ahead.
// Each quad is split along its shorter diagonal (rings may be twisted against each other).
void band(std::vector<std::array<int, 4>>& F, const std::vector<Vec3>& P, const std::vector<int>& a,
          const std::vector<int>& b, int region) {
  const int n = static_cast<int>(a.size());
  for (int p = 0; p < n; ++p) {
    const int q = (p + 1) % n;
    if ((P[a[p]] - P[b[q]]).squaredNorm() <= (P[a[q]] - P[b[p]]).squaredNorm()) {
      F.push_back({a[p], a[q], b[q], region});
      F.push_back({a[p], b[q], b[p], region});
    } else {
      F.push_back({a[p], a[q], b[p], region});
      F.push_back({a[q], b[q], b[p], region});
    }
  }
}

SurfaceMesh pack(const std::vector<Vec3>& P, const std::vector<std::array<int, 4>>& F,
                 std::vector<std::string> names) {
  Positions V(static_cast<int>(P.size()), 3);
  for (size_t i = 0; i < P.size(); ++i) V.row(i) = P[i].transpose();
  Faces Fm(static_cast<int>(F.size()), 3);
  Regions reg;
  reg.names = std::move(names);
  if (!reg.names.empty()) reg.id.resize(static_cast<int>(F.size()));
  for (size_t f = 0; f < F.size(); ++f) {
    Fm.row(f) << F[f][0], F[f][1], F[f][2];
    if (!reg.names.empty()) reg.id[f] = F[f][3];
  }
  return make_surface_mesh(std::move(V), std::move(Fm), std::move(reg));
}

enum TractRegion { kOvaryL = 0, kOvaryR, kHornL, kHornR, kBody, kCervix };

// Ring counts of the tract: 2n points per ring, trunk rings every `step` of meridian length,
// horn rings every 0.35 step: a horn is 0.38 times as wide as the body, so its triangles stay
// near-equilateral (and TetGen then fills the tract without Steiner points: Model-C).
struct TractCounts {
  int n, nt, nh;
  long vertices() const { return 1 + 2L * n * nt + (n - 1) + 2 * ((nh - 1) * 2L * n + 1); }
};

TractCounts tract_counts(const TractShape& sh, int n, double step, double trunk_len,
                         double horn_len) {
  return {n, std::max(2, static_cast<int>(std::lround(trunk_len / step))),
          std::max(3, static_cast<int>(std::lround(horn_len / (0.35 * step))))};
}

SurfaceMesh build_tract(const TractShape& sh, const TractCounts& k) {
  const int n = k.n;
  const int R = 2 * n;  // points per ring, trunk and horns alike
  std::vector<Vec3> P;
  std::vector<std::array<int, 4>> F;

  // --- trunk: pole at z = 0, rings up to the junction at z = zj ---
  auto tr = [&](double z) { return trunk_radius(sh, z); };
  const int nt = k.nt;
  const std::vector<double> zt = meridian_stations(sh.zj, tr, nt);
  P.push_back(Vec3(0, 0, 0));
  std::vector<std::vector<int>> trunk(nt + 1);
  std::vector<double> ring_z(nt + 1);
  for (int i = 1; i <= nt; ++i) {
    const double z = zt[i], r = tr(z);
    ring_z[i] = z;
    // Consecutive rings are twisted by half a step (the top ring, which the horns share, is
    // not): the points are then not co-spherical and TetGen needs no Steiner points inside.
    const double twist = (nt - i) % 2 ? 0.5 : 0.0;
    for (int p = 0; p < R; ++p) {
      const double th = std::numbers::pi * (p + twist) / n;
      trunk[i].push_back(static_cast<int>(P.size()));
      P.push_back(Vec3(r * std::cos(th), r * std::sin(th), z));
    }
  }
  for (int p = 0; p < R; ++p) F.push_back({0, trunk[1][(p + 1) % R], trunk[1][p], kCervix});
  for (int i = 1; i < nt; ++i)
    band(F, P, trunk[i], trunk[i + 1],
         0.5 * (ring_z[i] + ring_z[i + 1]) < sh.z_region_split ? kCervix : kBody);

  // --- junction: seam points across the top ring, shared by both horns ---
  const std::vector<int>& top = trunk[nt];
  std::vector<int> seam(n);  // seam[m], m = 1..n-1, from back (y<0) to front
  for (int m = 1; m < n; ++m) {
    seam[m] = static_cast<int>(P.size());
    P.push_back(Vec3(0, -sh.r_body + 2 * sh.r_body * m / n, sh.zj));
  }
  std::vector<int> d_left(R), d_right(R);
  for (int p = 0; p <= n; ++p) {
    d_left[p] = top[(n / 2 + p) % R];       // front -> outer (-x) -> back
    d_right[p] = top[(3 * n / 2 + p) % R];  // back -> outer (+x) -> front
  }
  for (int m = 1; m < n; ++m) {
    d_left[n + m] = seam[m];       // back -> front
    d_right[n + m] = seam[n - m];  // front -> back
  }

  // --- left horn: rings from the D-shaped junction ring blended into circles ---
  const Curve c = left_horn_curve(sh);
  const double L = c.length();
  auto hr = [&](double s) { return horn_radius(sh, s / L); };
  const int nh = k.nh;
  const std::vector<double> sj = meridian_stations(L, hr, nh);
  const Vec3 c0 = c.pos(0);
  std::vector<std::vector<Vec3>> left(nh);  // ring positions, j = 1 .. nh-1
  for (int j = 1; j < nh; ++j) {
    const double s = sj[j], r = hr(s);
    const Vec3 cj = c.pos(s), T = c.tangent(s);
    // The curve is planar: B is the plane's normal, N = B x T (so N x B = T).
    const Vec3 B = horn_heading(sh).cross(Vec3(0, 0, 1)), N = B.cross(T).normalized();
    const double w = smoothstep(0, 0.05, s);
    const double twist = j % 2 ? 0.5 : 0.0;
    for (int p = 0; p < R; ++p) {
      // + yaw: the frame is turned by -yaw about z against the junction ring's x/y frame.
      const double phi = std::numbers::pi / 2 + std::numbers::pi * (p + twist) / n + sh.yaw;
      const Vec3 circle = cj + r * (std::cos(phi) * N + std::sin(phi) * B);
      const Vec3 d = P[d_left[p]] + (cj - c0);
      left[j].push_back((1 - w) * d + w * circle);
    }
  }
  const Vec3 tip = c.pos(L);
  // Right horn = mirror image (x -> -x); ring point p mirrors left point (n - p) mod R so the
  // ring stays counter-clockwise seen from ahead.
  auto mirror = [](Vec3 v) { return Vec3(-v.x(), v.y(), v.z()); };
  for (int side = 0; side < 2; ++side) {
    std::vector<int> prev = side == 0 ? d_left : d_right;
    const int horn = side == 0 ? kHornL : kHornR, ovary = side == 0 ? kOvaryL : kOvaryR;
    for (int j = 1; j < nh; ++j) {
      std::vector<int> ring(R);
      for (int p = 0; p < R; ++p) {
        ring[p] = static_cast<int>(P.size());
        P.push_back(side == 0 ? left[j][p] : mirror(left[j][((n - p) % R + R) % R]));
      }
      band(F, P, prev, ring, 0.5 * (sj[j - 1] + sj[j]) / L >= sh.u_ovary ? ovary : horn);
      prev = std::move(ring);
    }
    const int pole = static_cast<int>(P.size());
    P.push_back(side == 0 ? tip : mirror(tip));
    for (int p = 0; p < R; ++p) F.push_back({prev[p], prev[(p + 1) % R], pole, ovary});
  }
  return pack(P, F, tract_region_names());
}

TractShape tract_shape(std::uint64_t seed) {
  TractShape s;
  s.Rx *= 1 + 0.05 * jitter(seed, "horn-curl-x");
  s.Rz *= 1 + 0.05 * jitter(seed, "horn-curl-z");
  s.r_horn *= 1 + 0.05 * jitter(seed, "horn-radius");
  s.r_ovary *= 1 + 0.05 * jitter(seed, "ovary-radius");
  return s;
}

}  // namespace

const std::vector<std::string>& tract_region_names() {
  static const std::vector<std::string> names{"ovary_left", "ovary_right", "horn_left",
                                              "horn_right", "body",        "cervix"};
  return names;
}

SurfaceMesh generate_tract(const TractOptions& opt) {
  if (opt.target_vertices < 200 || opt.target_vertices > 2000000)
    throw InputError("tract: --vertices must be between 200 and 2000000, got " +
                     std::to_string(opt.target_vertices));
  const TractShape sh = tract_shape(opt.seed);
  const double trunk_len = meridian_length(sh.zj, [&](double z) { return trunk_radius(sh, z); });
  const Curve c = left_horn_curve(sh);
  const double L = c.length();
  const double horn_len = meridian_length(L, [&](double s) { return horn_radius(sh, s / L); });
  // Choose n (points around) for which near-equilateral triangles (step = spacing around the
  // body, pi r_body / n) come closest to the target, then fine-tune the step along the tract.
  int best_n = 4;
  long best_err = -1;
  for (int n = 4; n <= 2000; n += 2) {
    const long err = std::labs(
        tract_counts(sh, n, std::numbers::pi * sh.r_body / n, trunk_len, horn_len).vertices() -
        opt.target_vertices);
    if (best_err < 0 || err < best_err) {
      best_err = err;
      best_n = n;
    }
  }
  const double h0 = std::numbers::pi * sh.r_body / best_n;
  double lo = std::log(0.8 * h0), hi = std::log(1.25 * h0);  // counts fall as the step grows
  TractCounts best = tract_counts(sh, best_n, h0, trunk_len, horn_len);
  for (int it = 0; it < 60 && best.vertices() != opt.target_vertices; ++it) {
    const double mid = 0.5 * (lo + hi);
    const TractCounts k = tract_counts(sh, best_n, std::exp(mid), trunk_len, horn_len);
    if (std::labs(k.vertices() - opt.target_vertices) <
        std::labs(best.vertices() - opt.target_vertices))
      best = k;
    if (k.vertices() > opt.target_vertices)
      lo = mid;
    else
      hi = mid;
  }
  return build_tract(sh, best);
}

SurfaceMesh generate_stomach(std::uint64_t seed) {
  const int S = 6, R = 32;
  const double fundus = 0.045 * (1 + 0.05 * jitter(seed, "stomach-fundus"));
  const double pylorus = 0.012 * (1 + 0.05 * jitter(seed, "stomach-pylorus"));
  std::vector<Vec3> P;
  std::vector<std::array<int, 4>> F;
  std::vector<std::vector<int>> rings(R);
  // Centreline: an arc of radius 0.08 m in the xz plane over 1.3 pi (0.33 m), J-shaped.
  const double rc = 0.08, a0 = 0.6 * std::numbers::pi, a1 = 1.9 * std::numbers::pi;
  for (int i = 0; i < R; ++i) {
    const double u = static_cast<double>(i) / (R - 1);
    const double a = a0 + (a1 - a0) * u;
    const Vec3 c(rc * std::cos(a), 0, rc * std::sin(a));
    const Vec3 T = Vec3(-std::sin(a), 0, std::cos(a));
    const Vec3 B(0, 1, 0), N = B.cross(T);
    // Wide fundus, narrowing body, narrow pylorus.
    const double r = pylorus + (fundus - pylorus) * (1 - smoothstep(0.1, 0.95, u));
    for (int p = 0; p < S; ++p) {
      const double phi = 2 * std::numbers::pi * p / S;
      rings[i].push_back(static_cast<int>(P.size()));
      P.push_back(c + r * (std::cos(phi) * N + std::sin(phi) * B));
    }
  }
  for (int i = 0; i + 1 < R; ++i) band(F, P, rings[i], rings[i + 1], 0);
  return pack(P, F, {});
}

int sphere_frequency_for(int target_vertices) {
  if (target_vertices < 12 || target_vertices > 4000000)
    throw InputError("sphere: --vertices must be between 12 and 4000000, got " +
                     std::to_string(target_vertices));
  int nu = std::max(1, static_cast<int>(std::lround(std::sqrt((target_vertices - 2) / 10.0))));
  // Round in vertex space, not in nu.
  auto count = [](int f) { return 10L * f * f + 2; };
  if (nu > 1 && std::labs(count(nu - 1) - target_vertices) < std::labs(count(nu) - target_vertices))
    --nu;
  if (std::labs(count(nu + 1) - target_vertices) < std::labs(count(nu) - target_vertices)) ++nu;
  return nu;
}

SurfaceMesh generate_sphere(int target_vertices) {
  const int nu = sphere_frequency_for(target_vertices);
  const double radius = 0.05;
  const double g = (1 + std::sqrt(5.0)) / 2;
  const std::array<Vec3, 12> ico = {Vec3(-1, g, 0), Vec3(1, g, 0), Vec3(-1, -g, 0), Vec3(1, -g, 0),
                                    Vec3(0, -1, g), Vec3(0, 1, g), Vec3(0, -1, -g), Vec3(0, 1, -g),
                                    Vec3(g, 0, -1), Vec3(g, 0, 1), Vec3(-g, 0, -1), Vec3(-g, 0, 1)};
  std::array<std::array<int, 3>, 20> faces = {
      {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
       {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
       {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}}};
  std::vector<Vec3> P;
  // A point of the subdivision is a weighted sum of icosahedron corners; the canonical
  // (sorted) list of (corner, weight) identifies points shared between faces.
  std::map<std::array<int, 6>, int> ids;
  auto point = [&](const std::array<int, 3>& f, int i, int j) {
    std::array<std::pair<int, int>, 3> w = {{{f[0], nu - i - j}, {f[1], i}, {f[2], j}}};
    // Zero weights out (they would make the key depend on the face), then sort by corner.
    for (auto& x : w)
      if (x.second == 0) x.first = -1;
    std::sort(w.begin(), w.end());
    std::array<int, 6> key{};
    for (int k = 0; k < 3; ++k) {
      key[2 * k] = w[k].first;
      key[2 * k + 1] = w[k].second;
    }
    auto [it, fresh] = ids.emplace(key, static_cast<int>(P.size()));
    if (fresh) {
      Vec3 p = Vec3::Zero();
      for (auto& [c, wt] : w)
        if (wt) p += wt * ico[c];  // zero weights carry no corner (c = -1)
      P.push_back(radius * p.normalized());
    }
    return it->second;
  };
  std::vector<std::array<int, 4>> F;
  for (auto f : faces) {
    const Vec3 n = (ico[f[1]] - ico[f[0]]).cross(ico[f[2]] - ico[f[0]]);
    if (n.dot(ico[f[0]] + ico[f[1]] + ico[f[2]]) < 0) std::swap(f[1], f[2]);
    for (int i = 0; i < nu; ++i)
      for (int j = 0; i + j < nu; ++j) {
        F.push_back({point(f, i, j), point(f, i + 1, j), point(f, i, j + 1), 0});
        if (i + j + 1 < nu)
          F.push_back({point(f, i + 1, j), point(f, i + 1, j + 1), point(f, i, j + 1), 0});
      }
  }
  return pack(P, F, {});
}

}  // namespace palplab::mesh
