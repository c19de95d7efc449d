// The procedural shoulder of the needle-insertion scene (issue 16): nested closed surfaces and
// the tissue seeds for TetGen. See generate.hpp for the geometry.
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "common/input_error.hpp"
#include "engine/mesh/generate.hpp"

namespace palplab::mesh {

namespace {

// Skin surface: the rounded box |x/a|^3 + |y/b|^3 + |z/c|^3 = 1 (a superellipsoid).
constexpr double kSkinA = 0.075, kSkinB = 0.070, kSkinC = 0.080, kSkinP = 3.0;
constexpr double kSkinThickness = 0.002;  // radial, m
constexpr double kFatThickness = 0.010;   // radial, below the skin, m
// Joint: humeral head sphere, membrane (capsule) cap and glenoid cap, all centred on the head.
const Vec3 kHead(0.022, 0.0, 0.0);
constexpr double kHeadRadius = 0.024;
constexpr double kMembraneInner = 0.0255, kMembraneOuter = 0.0275, kMembraneAngle = 40.0;
constexpr double kGlenoidInner = 0.029, kGlenoidOuter = 0.041, kGlenoidAngle = 32.0;
const Vec3 kAcromion(0.020, 0.0, 0.041);
const Vec3 kAcromionAxes(0.025, 0.015, 0.005);

// Tissue types (SPEC §4).
constexpr int kSkin = 100, kFat = 101, kMembrane = 107, kHumerus = 200, kScapula = 201,
              kDeltoid = 300;

double skin_radius(const Vec3& u) {
  const double s = std::pow(std::abs(u.x()) / kSkinA, kSkinP) +
                   std::pow(std::abs(u.y()) / kSkinB, kSkinP) +
                   std::pow(std::abs(u.z()) / kSkinC, kSkinP);
  return std::pow(s, -1.0 / kSkinP);
}

double ellipsoid_radius(const Vec3& u, const Vec3& axes) {
  return 1.0 / std::sqrt((u.array() / axes.array()).square().sum());
}

// Appends a part to the shoulder.
struct ShoulderBuilder {
  std::vector<Vec3> V;
  std::vector<std::array<int, 3>> F;
  std::vector<ShoulderPart> parts;

  int begin(const std::string& name, int parent, int inside) {
    ShoulderPart p;
    p.name = name;
    p.parent = parent;
    p.inside = inside;
    p.first_face = static_cast<int>(F.size());
    p.first_vertex = static_cast<int>(V.size());
    parts.push_back(p);
    return static_cast<int>(parts.size()) - 1;
  }
  void end() {
    ShoulderPart& p = parts.back();
    p.faces = static_cast<int>(F.size()) - p.first_face;
    p.vertices = static_cast<int>(V.size()) - p.first_vertex;
  }
  int add(const Vec3& p) {
    V.push_back(p);
    return static_cast<int>(V.size()) - 1;
  }
};

// A star-shaped closed surface: the icosphere's directions u mapped to centre + radius(u) u.
// Radial mapping keeps the icosphere's outward orientation.
template <class Radius>
void add_star(ShoulderBuilder& b, const SurfaceMesh& ico, const Vec3& centre, Radius radius) {
  const int base = static_cast<int>(b.V.size());
  for (int i = 0; i < ico.V.rows(); ++i) {
    const Vec3 u = row3(ico.V, i).normalized();
    b.add(centre + radius(u) * u);
  }
  for (int f = 0; f < ico.F.rows(); ++f)
    b.F.push_back({base + ico.F(f, 0), base + ico.F(f, 1), base + ico.F(f, 2)});
}

// Stitches ring A (nearer the pole) to ring B: triangles (A_i, B_j, B_j+1) and (A_i, B_j, A_i+1),
// advancing by angle so that rings of different vertex counts join without slivers. With
// `flip` the triangles are reversed (the inner face of a shell looks the other way).
void stitch(ShoulderBuilder& b, const std::vector<int>& A, const std::vector<int>& B, bool flip) {
  auto tri = [&](int x, int y, int z) {
    if (flip)
      b.F.push_back({x, z, y});
    else
      b.F.push_back({x, y, z});
  };
  const int p = static_cast<int>(A.size()), q = static_cast<int>(B.size());
  if (p == 1) {
    for (int j = 0; j < q; ++j) tri(A[0], B[j], B[(j + 1) % q]);
    return;
  }
  int i = 0, j = 0;
  while (i < p || j < q) {
    // Compare the angles of the next vertices exactly: (j+1)/q <= (i+1)/p.
    const bool advance_b =
        j < q && (i == p || static_cast<long>(j + 1) * p <= static_cast<long>(i + 1) * q);
    if (advance_b) {
      tri(A[i % p], B[j % q], B[(j + 1) % q]);
      ++j;
    } else {
      tri(A[i % p], B[j % q], A[(i + 1) % p]);
      ++i;
    }
  }
}

// A closed shell cap: the spherical caps of radii r_in < r_out around `centre`, within
// `half_angle` degrees of the unit axis w, joined by a conical rim. `rings` rings from the pole
// to the rim; ring i has round(around · i / rings) vertices (at least 3).
void add_shell_cap(ShoulderBuilder& b, const Vec3& centre, const Vec3& w, double r_in, double r_out,
                   double half_angle, int rings, int around) {
  Vec3 e1 = w.unitOrthogonal();
  Vec3 e2 = w.cross(e1);
  const double theta_max = half_angle * std::numbers::pi / 180;
  auto face = [&](double r, bool flip) {
    std::vector<int> prev{b.add(centre + r * w)};
    for (int i = 1; i <= rings; ++i) {
      const double th = theta_max * i / rings;
      const int m = std::max(3, static_cast<int>(std::lround(double(around) * i / rings)));
      std::vector<int> ring(m);
      for (int j = 0; j < m; ++j) {
        const double ph = 2 * std::numbers::pi * j / m;
        ring[j] = b.add(centre + r * (std::cos(th) * w +
                                      std::sin(th) * (std::cos(ph) * e1 + std::sin(ph) * e2)));
      }
      stitch(b, prev, ring, flip);
      prev = std::move(ring);
    }
    return prev;  // the rim ring
  };
  const std::vector<int> outer = face(r_out, false);
  const std::vector<int> inner = face(r_in, true);
  // The rim: the outer face holds the edges o_j -> o_j+1, the inner face i_j+1 -> i_j.
  const int m = static_cast<int>(outer.size());
  for (int j = 0; j < m; ++j) {
    const int o0 = outer[j], o1 = outer[(j + 1) % m], i0 = inner[j], i1 = inner[(j + 1) % m];
    b.F.push_back({o1, o0, i0});
    b.F.push_back({o1, i0, i1});
  }
}

}  // namespace

Shoulder generate_shoulder(const ShoulderOptions& opt) {
  if (opt.layer_vertices < 162 || opt.layer_vertices > 40962)
    throw InputError(
        "shoulder: --vertices (vertices per skin layer) must be between 162 and 40962, got " +
        std::to_string(opt.layer_vertices));
  const int nu = sphere_frequency_for(opt.layer_vertices);
  const SurfaceMesh layer = generate_sphere(opt.layer_vertices);
  // Bones get about the same edge length as the layers (head: a third of the skin's radius).
  const SurfaceMesh head = generate_sphere(std::max(162, 10 * (nu * 2 / 3) * (nu * 2 / 3) + 2));
  const SurfaceMesh acromion = generate_sphere(std::max(162, 10 * (nu / 2) * (nu / 2) + 2));
  const int rings = std::max(4, nu / 2), around = std::max(18, 3 * nu);

  ShoulderBuilder b;
  const Vec3 origin = Vec3::Zero();
  b.begin("skin_outer", -1, kSkin);
  add_star(b, layer, origin, [](const Vec3& u) { return skin_radius(u); });
  b.end();
  b.begin("skin_inner", 0, kFat);
  add_star(b, layer, origin, [](const Vec3& u) { return skin_radius(u) - kSkinThickness; });
  b.end();
  b.begin("fat_inner", 1, kDeltoid);
  add_star(b, layer, origin,
           [](const Vec3& u) { return skin_radius(u) - kSkinThickness - kFatThickness; });
  b.end();
  b.begin("humerus", 2, kHumerus);
  add_star(b, head, kHead, [](const Vec3&) { return kHeadRadius; });
  b.end();
  const Vec3 medial(-1, 0, 0);
  b.begin("membrane", 2, kMembrane);
  add_shell_cap(b, kHead, medial, kMembraneInner, kMembraneOuter, kMembraneAngle, rings, around);
  b.end();
  b.begin("glenoid", 2, kScapula);
  add_shell_cap(b, kHead, medial, kGlenoidInner, kGlenoidOuter, kGlenoidAngle, rings + 2,
                around + 6);
  b.end();
  b.begin("acromion", 2, kScapula);
  add_star(b, acromion, kAcromion,
           [](const Vec3& u) { return ellipsoid_radius(u, kAcromionAxes); });
  b.end();

  Shoulder s;
  Positions V(b.V.size(), 3);
  for (size_t i = 0; i < b.V.size(); ++i) V.row(i) = b.V[i].transpose();
  Faces F(b.F.size(), 3);
  for (size_t f = 0; f < b.F.size(); ++f) F.row(f) << b.F[f][0], b.F[f][1], b.F[f][2];
  s.surface = make_surface_mesh(std::move(V), std::move(F));
  s.parts = b.parts;

  // Seeds: the layers along the posterior-most icosphere direction (vertex rays hit each layer
  // surface exactly at a vertex, so the midpoints lie strictly between them; nothing else is
  // there), the bones and the membrane at their poles / centres.
  int back = 0;
  for (int i = 1; i < layer.V.rows(); ++i)
    if (layer.V(i, 1) < layer.V(back, 1)) back = i;
  const Vec3 u = row3(layer.V, back).normalized();
  const double r0 = skin_radius(u);
  auto seed = [&](const Vec3& p, int tissue) {
    RegionSeed g;
    g.index = static_cast<int>(s.seeds.size()) + 1;
    g.point = p;
    g.region_id = tissue;
    s.seeds.push_back(g);
  };
  seed((r0 - kSkinThickness / 2) * u, kSkin);
  seed((r0 - kSkinThickness - kFatThickness / 2) * u, kFat);
  seed((r0 - kSkinThickness - kFatThickness - 0.005) * u, kDeltoid);
  seed(kHead, kHumerus);
  seed(kHead + medial * (kMembraneInner + kMembraneOuter) / 2, kMembrane);
  seed(kHead + medial * (kGlenoidInner + kGlenoidOuter) / 2, kScapula);
  seed(kAcromion, kScapula);
  return s;
}

}  // namespace palplab::mesh
