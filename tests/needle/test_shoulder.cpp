// The procedural shoulder (issue 16): nested closed surfaces, tetrahedralization by tissue,
// boundary extraction without bone-facing faces, and a needle through it.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>

#include "common/input_error.hpp"
#include "engine/mesh/check.hpp"
#include "engine/mesh/generate.hpp"
#include "engine/mesh/materials.hpp"
#include "engine/mesh/tetrahedralize.hpp"
#include "engine/models/needle.hpp"

namespace palplab::mesh {
namespace {

constexpr int kCoarse = 642;

SurfaceMesh part_mesh(const Shoulder& s, const ShoulderPart& p) {
  Positions V = s.surface.V.middleRows(p.first_vertex, p.vertices);
  Faces F = s.surface.F.middleRows(p.first_face, p.faces).array() - p.first_vertex;
  return make_surface_mesh(std::move(V), std::move(F));
}

// Generalised winding number of a closed surface at q (Van Oosterom & Strackee solid angles):
// 1 inside, 0 outside.
double winding(const SurfaceMesh& m, const Vec3& q) {
  double w = 0;
  for (int f = 0; f < m.F.rows(); ++f) {
    const Vec3 a = row3(m.V, m.F(f, 0)) - q, b = row3(m.V, m.F(f, 1)) - q,
               c = row3(m.V, m.F(f, 2)) - q;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double num = a.dot(b.cross(c));
    const double den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    w += 2 * std::atan2(num, den);
  }
  return w / (4 * std::numbers::pi);
}

const Shoulder& coarse() {
  static const Shoulder s = generate_shoulder({kCoarse});
  return s;
}

const TetMesh& coarse_tets() {
  static const TetMesh m = [] {
    TetOptions o;
    o.seeds = coarse().seeds;
    return tetrahedralize(coarse().surface, o);
  }();
  return m;
}

TEST(Shoulder, Deterministic) {
  const Shoulder again = generate_shoulder({kCoarse});
  EXPECT_EQ(again.surface.V, coarse().surface.V);
  EXPECT_EQ(again.surface.F, coarse().surface.F);
  TetOptions o;
  o.seeds = again.seeds;
  const TetMesh t = tetrahedralize(again.surface, o);
  EXPECT_EQ(t.V, coarse_tets().V);
  EXPECT_EQ(t.T, coarse_tets().T);
  EXPECT_EQ(t.attribute, coarse_tets().attribute);
  EXPECT_THROW(generate_shoulder({100}), palplab::InputError);
}

TEST(Shoulder, SurfacesAreClosedNonIntersectingAndNested) {
  const Shoulder& s = coarse();
  ASSERT_EQ(s.parts.size(), 7u);
  const CheckReport r = check_surface(s.surface);
  EXPECT_TRUE(r.clean()) << (r.counts.empty() ? "" : r.counts.begin()->first);
  EXPECT_TRUE(self_intersections(s.surface.V, s.surface.F).empty());
  std::vector<SurfaceMesh> parts;
  for (const ShoulderPart& p : s.parts) {
    parts.push_back(part_mesh(s, p));
    EXPECT_TRUE(is_closed_manifold(parts.back())) << p.name;
    EXPECT_EQ(genus(parts.back()), 0) << p.name;
    EXPECT_GT(enclosed_volume(parts.back().V, parts.back().F), 0) << p.name << " outward";
  }
  // Every vertex of a part lies inside its parent and outside every sibling.
  for (size_t i = 0; i < parts.size(); ++i)
    for (size_t j = 0; j < parts.size(); ++j) {
      if (i == j) continue;
      const bool parent = static_cast<int>(j) == s.parts[i].parent;
      const bool sibling = s.parts[j].parent == s.parts[i].parent;
      if (!parent && !sibling) continue;
      for (int v = 0; v < parts[i].V.rows(); v += 3) {
        const double w = winding(parts[j], row3(parts[i].V, v));
        ASSERT_NEAR(w, parent ? 1.0 : 0.0, 1e-6)
            << s.parts[i].name << " vertex " << v << " vs " << s.parts[j].name;
      }
    }
  // Every seed lies in the region its tissue names: inside the part with that tissue, outside
  // that part's children.
  for (const RegionSeed& g : s.seeds) {
    int inside = -1;  // innermost part containing the seed
    for (size_t j = 0; j < parts.size(); ++j)
      if (winding(parts[j], g.point) > 0.5) inside = static_cast<int>(j);
    ASSERT_GE(inside, 0);
    EXPECT_EQ(s.parts[inside].inside, g.region_id) << "seed " << g.index;
  }
}

TEST(Shoulder, TetRegionsMatchTheTissueVolumes) {
  const Shoulder& s = coarse();
  const TetMesh& m = coarse_tets();
  EXPECT_TRUE(check_tets(m).clean());
  std::map<int, double> tet_volume;
  for (int t = 0; t < m.T.rows(); ++t) tet_volume[m.attribute[t]] += m.volume[t];
  // Enclosed volume of each tissue: its surface's volume minus its children's.
  std::map<int, double> want;
  for (size_t i = 0; i < s.parts.size(); ++i) {
    const SurfaceMesh p = part_mesh(s, s.parts[i]);
    const double v = enclosed_volume(p.V, p.F);
    want[s.parts[i].inside] += v;
    if (s.parts[i].parent >= 0) want[s.parts[s.parts[i].parent].inside] -= v;
  }
  ASSERT_EQ(tet_volume.size(), want.size());
  for (auto& [tissue, v] : want) {
    ASSERT_TRUE(tet_volume.count(tissue)) << tissue;
    EXPECT_NEAR(tet_volume[tissue], v, 0.02 * v) << "tissue " << tissue;
  }
  EXPECT_EQ(want.size(), 6u);  // 100 101 107 200 201 300
}

TEST(Shoulder, BoundaryExtractionSkipsBoneFacingFaces) {
  const TetMesh& m = coarse_tets();
  const Tets N = tet_neighbours(m);
  auto rigid = [](int a) { return a >= 200 && a <= 299; };
  BoundaryOptions all;
  all.tissue_interfaces = true;
  BoundaryOptions skip = all;
  skip.skip_towards_rigid = true;
  skip.skip_rigid_outer = true;
  const BoundaryFaces fa = boundary_faces(m, all), fs = boundary_faces(m, skip);
  int bone_facing = 0;
  for (int i = 0; i < fa.F.rows(); ++i) {
    const int t = fa.tet[i], nb = N(t, fa.local[i]);
    if (rigid(m.attribute[t]) || (nb >= 0 && rigid(m.attribute[nb]))) ++bone_facing;
  }
  EXPECT_GT(bone_facing, 100);  // the humerus, glenoid and acromion surfaces
  for (int i = 0; i < fs.F.rows(); ++i) {
    const int t = fs.tet[i], nb = N(t, fs.local[i]);
    EXPECT_FALSE(rigid(m.attribute[t])) << "face " << i;
    EXPECT_FALSE(nb >= 0 && rigid(m.attribute[nb])) << "face " << i;
  }
  EXPECT_EQ(fs.F.rows(), fa.F.rows() - bone_facing);
  // The O(n) extraction agrees with the O(n^2) baseline on this mesh.
  EXPECT_EQ(fs.F, boundary_faces_brute_force(m, skip).F);
}

TEST(Shoulder, NeedleThroughTheCapsuleHitsTheHumeralHead) {
  // A radial line through the capsule 36° posterior of its pole (outside the glenoid's 32°):
  // skin, fat, deltoid, membrane, the 1.5 mm gap (muscle), then the humeral head.
  const TetMesh& m = coarse_tets();
  engine::NeedleModel needle(m, default_materials());
  const double a = 36 * std::numbers::pi / 180;
  const Vec3 head(0.022, 0, 0), out(-std::cos(a), -std::sin(a), 0);
  const Vec3 axis = -out;
  std::vector<int> entered;
  int bone = -1;
  double first_distance = -1;
  for (double r = 0.09; r >= 0.020; r -= 2e-5) {
    const engine::NeedleStep s = needle.step(head + r * out, axis);
    if (s.inserted && first_distance < 0) {
      first_distance = s.tip_to_target;
      // At the skin the membrane's outer surface (radius 27.5 mm) is the nearest target point
      // along this radius: distance = |entry - head| - 27.5 mm, up to the facets' sagitta.
      EXPECT_NEAR(s.tip_to_target, (s.tip - head).norm() - 0.0275, 5e-4);
    }
    for (auto& e : s.events) {
      if (e.kind == engine::NeedleEvent::Kind::tissue_entered) entered.push_back(e.tissue);
      if (e.kind == engine::NeedleEvent::Kind::bone_contact) bone = e.tissue;
      if (e.kind == engine::NeedleEvent::Kind::target_reached) {
        EXPECT_NEAR((e.position - head).norm(), 0.0275, 3e-4);
      }
    }
  }
  EXPECT_EQ(entered, (std::vector<int>{100, 101, 300, 107, 300}));
  EXPECT_EQ(bone, 200);
  EXPECT_GT(first_distance, 0.02);
}

}  // namespace
}  // namespace palplab::mesh
