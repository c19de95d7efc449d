// Contact hard cases of issue 10, per prototype: a contact that starts inside the organ, a 10 m/s
// push (no tunnelling), sliding across node boundaries (bounded force change per step), a 3 cm
// jump of the device in one step (force limited, scene recovers), and stiff tissue at h = 1 ms.
// The god-object tracker itself is checked on an octahedron (engine/haptics/contact.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <vector>

#include "common/input_error.hpp"
#include "engine/haptics/contact.hpp"
#include "engine/haptics/scene_config.hpp"
#include "engine/mesh/generate.hpp"
#include "engine/mesh/io.hpp"
#include "prototypes/factory.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {

std::string proto(const std::string& id) {
  return std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + id + ".json";
}

Scene make(const std::string& id, const std::function<void(SceneConfig&)>& edit = {}) {
  SceneConfig cfg = prototypes::load_prototype(proto(id));
  if (edit) edit(cfg);
  return make_scene(cfg);
}

struct Track {
  std::vector<Eigen::Vector3d> F;
  std::vector<int> node;
  std::vector<bool> contact;
  std::vector<Event> events;
  int count(EventKind k) const {
    int n = 0;
    for (const Event& e : events) n += e.kind == k;
    return n;
  }
  double fmax() const {
    double m = 0;
    for (const auto& f : F) m = std::max(m, f.norm());
    return m;
  }
  bool finite() const {
    for (const auto& f : F)
      if (!f.allFinite()) return false;
    return true;
  }
};

void step(Scene& s, const Eigen::Vector3d& x, Track& r) {
  const Rendered o = s.step(x);
  r.F.push_back(o.force);
  r.node.push_back(o.contact_node);
  r.contact.push_back(o.contact);
  for (const Event& e : o.events) r.events.push_back(e);
}

// A point of the body region and its outward normal.
struct Site {
  Eigen::Vector3d p, n;
};
Site site(const Scene& s, const char* region = "body") {
  const SceneGeometry& g = s.geometry();
  const int node = g.region_node(region);
  return {g.V.row(node).transpose(), g.N.row(node).transpose()};
}

const char* kAll[] = {"A", "B", "C", "D"};

// --- the tracker on a closed octahedron (|x|+|y|+|z| = 1) ---

struct Octa {
  mesh::Positions V, N;
  mesh::Faces F;
  Octa() {
    V.resize(6, 3);
    V << 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1;
    N = V;
    F.resize(8, 3);
    int k = 0;
    for (int sx : {0, 1})
      for (int sy : {2, 3})
        for (int sz : {4, 5}) {
          // ccw seen from outside: the sign of the triple product of the three axes
          const double s = (sx == 0 ? 1 : -1) * (sy == 2 ? 1 : -1) * (sz == 4 ? 1 : -1);
          if (s > 0)
            F.row(k++) << sx, sy, sz;
          else
            F.row(k++) << sx, sz, sy;
        }
  }
};

}  // namespace

TEST(ContactTracker, InsideTestAndClosestPointOnAnOctahedron) {
  Octa o;
  ContactTracker t(o.V, o.N, o.F);
  EXPECT_NEAR(t.winding_number({0.1, 0.2, -0.1}), 1.0, 1e-12);
  EXPECT_NEAR(t.winding_number({0.9, 0.9, 0.0}), 0.0, 1e-12);
  EXPECT_NEAR(t.winding_number({5, -3, 2}), 0.0, 1e-12);
  // Closest point from the centre side of face (+,+,+): the face's own projection.
  const SurfacePoint c = t.closest_point({0.2, 0.2, 0.2});
  EXPECT_NEAR(c.p.sum(), 1.0, 1e-12);
  EXPECT_NEAR(c.p.x(), 1.0 / 3, 1e-12);
  EXPECT_NEAR(c.w.sum(), 1.0, 1e-12);
}

TEST(ContactTracker, FastPathIsCaughtAndTheProxyStaysOnTheEntrySide) {
  Octa o;
  ContactTracker t(o.V, o.N, o.F);
  t.reset();
  const Eigen::Vector3d out(0.6, 0.6, 0.6);  // outside (|x|_1 = 1.8)
  t.update(out, out);                        // side unknown -> outside
  EXPECT_FALSE(t.engaged());
  // One step from outside to deep inside past the centre: caught on the entry face.
  const Eigen::Vector3d deep(-0.1, -0.1, -0.1);
  t.update(out, deep);
  ASSERT_TRUE(t.engaged());
  EXPECT_GT(t.proxy().p.minCoeff(), -1e-12);  // the (+,+,+) face
  EXPECT_NEAR(t.depth(), (t.proxy().p - deep).dot(t.normal()), 1e-15);
  EXPECT_GT(t.depth(), 0.5);
  // The nearest face is now (-,-,-); the proxy does not jump there.
  EXPECT_LT(t.closest_point(deep).p.maxCoeff(), 1e-12);
  t.update(deep, deep);
  EXPECT_GT(t.proxy().p.minCoeff(), -1e-12);
  // Back out through the entry face: the contact ends.
  t.update(deep, out);
  EXPECT_FALSE(t.engaged());
  // A path that misses the organ never engages.
  t.update(out, Eigen::Vector3d(3, 3, -3));
  EXPECT_FALSE(t.engaged());
}

TEST(ContactTracker, StartInsideEngagesAtTheClosestPoint) {
  Octa o;
  ContactTracker t(o.V, o.N, o.F);
  t.reset();
  const Eigen::Vector3d x(0.5, 0.1, 0.1);  // inside, nearest the (+,+,+) face
  t.update(x, x);
  ASSERT_TRUE(t.engaged());
  EXPECT_TRUE(t.started_inside());
  EXPECT_NEAR((t.proxy().p - x).norm(), (1.0 - 0.7) / std::sqrt(3.0), 1e-12);
  t.update(x, x);
  EXPECT_FALSE(t.started_inside());  // only the first step
}

TEST(ContactTracker, ProxyMovesContinuouslyOverARidge) {
  // Slide under the ridge between faces (+,+,+) and (+,-,+). Inside a ridge the closest face
  // changes at the bisector (y = 0 here) and a closest-point contact jumps there (by 0.41 on
  // this path). The proxy is the point whose shaded normal passes through the device: it
  // crosses the edge continuously, each step moving it by at most a few device steps (the
  // shaded normal turns fast on this coarse shape: 90 degrees over one face).
  Octa o;
  ContactTracker t(o.V, o.N, o.F);
  t.reset();
  Eigen::Vector3d prev(0.6, 0.3, 0.6);
  t.update(prev, prev);
  ASSERT_FALSE(t.engaged());
  Eigen::Vector3d x(0.3, 0.3, 0.2);
  t.update(prev, x);
  ASSERT_TRUE(t.engaged());
  Eigen::Vector3d p = t.proxy().p;
  double worst = 0;
  for (int k = 1; k <= 600; ++k) {
    prev = x;
    x = Eigen::Vector3d(0.3, 0.3 - k * 1e-3, 0.2);
    t.update(prev, x);
    ASSERT_TRUE(t.engaged()) << k;
    EXPECT_NEAR((t.proxy().p - x).cross(t.normal()).norm(), 0.0, 1e-6)
        << k;  // x on p's normal (fixed point to ~1e-8 here)
    worst = std::max(worst, (t.proxy().p - p).norm());
    p = t.proxy().p;
  }
  EXPECT_LT(p.y(), -0.1);  // it did cross to the other face
  std::printf("largest proxy move per 1e-3 device step: %.4g\n", worst);
  EXPECT_LE(worst, 5e-3);
}

// --- scenes, every prototype ---

TEST(ContactHard, ContactStartingInsideIsBoundedAndLogged) {
  // The issue: a contact that starts inside gave 0 N, then a 9.5 N jump. Now the first step
  // renders the penetration's force (k d, clamped at the device limit) and logs contact_inside;
  // holding still changes nothing for a rigid surface, and nothing jumps afterwards.
  for (const char* id : kAll) {
    Scene s = make(id);
    const Site w = site(s);
    const double k = s.config().contact.stiffness, limit = s.config().contact.force_limit;
    Track r;
    const double d0 = 0.004;
    for (int i = 0; i < 300; ++i) step(s, w.p - (d0 + 1e-5 * i) * w.n, r);  // 1 cm/s deeper
    ASSERT_TRUE(r.finite()) << id;
    EXPECT_TRUE(r.contact[0]) << id;
    ASSERT_EQ(r.count(EventKind::contact_inside), 1) << id;
    const Event& e = r.events[0];
    EXPECT_EQ(e.kind, EventKind::contact_inside) << id;
    EXPECT_GT(e.value, 0.5 * d0) << id;
    EXPECT_LE(e.value, d0 + 1e-9) << id;
    EXPECT_LE(r.fmax(), limit + 1e-12) << id;
    // The first force is what the penetration implies: never more than k d (the coupling of a
    // deformable model yields, so it may be less), for the rigid ones exactly k times the depth.
    EXPECT_LE(r.F[0].norm(), k * d0 * 1.001 + 1e-12) << id;
    if (std::string(id) == "A" || std::string(id) == "B") {
      EXPECT_NEAR(r.F[0].norm(), k * e.value, 1e-9) << id;
    }
    // After the first step the force changes smoothly: at most k times the device's motion
    // per step (1e-5 m) for the rigid ones; for C and D the tissue relaxes under the probe, so
    // allow its first-contact transient but no jump larger than the initial force.
    for (size_t i = 1; i < r.F.size(); ++i) {
      const double df = (r.F[i] - r.F[i - 1]).norm();
      if (std::string(id) == "A" || std::string(id) == "B")
        ASSERT_LE(df, 2.0 * k * 1e-5) << id << " step " << i;
      else
        ASSERT_LE(df, r.F[0].norm() + 0.05) << id << " step " << i;
    }
  }
}

TEST(ContactHard, TenMetresPerSecondDoesNotTunnel) {
  // 10 m/s is 1 cm per 1 ms step: the old nearest-node capture missed the surface and the
  // device ended up inside with no force (prototype B). The path test catches the crossing; the
  // force stays on the side of entry (pushing the hand back out) all the way to 4 cm.
  for (const char* id : kAll) {
    Scene s = make(id);
    const Site w = site(s);
    Track r;
    for (int i = 0; i <= 6; ++i) step(s, w.p - (-0.02 + 0.01 * i) * w.n, r);  // to 4 cm deep
    for (int i = 0; i < 200; ++i) step(s, w.p - 0.04 * w.n, r);               // hold
    ASSERT_TRUE(r.finite()) << id;
    for (size_t i = 3; i < r.F.size(); ++i) {
      ASSERT_TRUE(r.contact[i]) << id << " step " << i;
      ASSERT_GT(r.F[i].dot(w.n), 0.0) << id << " step " << i;
    }
    EXPECT_LE(r.fmax(), s.config().contact.force_limit + 1e-12) << id;
    EXPECT_EQ(r.count(EventKind::contact_inside), 0) << id;
  }
}

TEST(ContactHard, SlidingAcrossNodesChangesTheForceBoundedly) {
  // At 4 mm depth, slide 1 cm sideways at 5 cm/s (50 um per step) across several nodes. The
  // old node-based contact jumped by up to 1 N when the nearest node changed. Now, for a rigid
  // surface, f = k d n(p) with the proxy p moving with the device and the shaded normal n
  // continuous: a step changes f by about k |dx| (1 + d |dn/dp|) — the bound below is 4 k |dx|
  // = 0.1 N for A and B (500 N/m), a tenth of the old jumps (measured: 0.0018 and 0.0009 N). C
  // and D still centre their probe patch on a node (engine/models/mass_spring*, fem_*: node-
  // based): measured 0.69 and 0.70 N at the one switch, bounded here at 1 N so it cannot grow.
  for (const char* id : kAll) {
    Scene s = make(id);
    const Site w = site(s);
    const double k = s.config().contact.stiffness;
    const double dx = 5e-5, depth = 0.004;
    // The body is curved: slide in the tangent direction along which the rest surface stays
    // within 1 mm of the start's tangent plane for 1 cm (checked on the rest geometry).
    const Eigen::Vector3d t0 = w.n.unitOrthogonal(), t1 = w.n.cross(t0);
    Eigen::Vector3d t = t0;
    double flattest = INFINITY;
    for (const Eigen::Vector3d& c : {t0, Eigen::Vector3d(-t0), t1, Eigen::Vector3d(-t1)}) {
      double dev = 0;
      for (int i = 0; i <= 10; ++i) {
        const Eigen::Vector3d q = w.p + i * 1e-3 * c;
        const int m = s.geometry().nearest_node(q);
        dev = std::max(dev, std::abs((s.geometry().V.row(m).transpose() - w.p).dot(w.n)));
      }
      if (dev < flattest) {
        flattest = dev;
        t = c;
      }
    }
    ASSERT_LT(flattest, 1e-3) << id;
    Track r;
    for (int i = 0; i <= 600; ++i)  // press to 4 mm at 1 cm/s
      step(s, w.p - (-0.002 + 1e-5 * i) * w.n, r);
    const size_t start = r.F.size();
    for (int i = 1; i <= 200; ++i) step(s, w.p - depth * w.n + i * dx * t, r);
    ASSERT_TRUE(r.finite()) << id;
    int switches = 0;
    double worst = 0;
    for (size_t i = start; i < r.F.size(); ++i) {
      ASSERT_TRUE(r.contact[i]) << id;
      switches += r.node[i] != r.node[i - 1];
      worst = std::max(worst, (r.F[i] - r.F[i - 1]).norm());
    }
    EXPECT_GE(switches, 1) << id << ": the slide must cross a node boundary";
    const bool rigid = std::string(id) == "A" || std::string(id) == "B";
    EXPECT_LE(worst, rigid ? 4.0 * k * dx : 1.0) << id;
    std::printf("%s: %d node switches, largest force change per step %.4f N\n", id, switches,
                worst);
  }
}

TEST(ContactHard, ThreeCentimetreJumpIsLimitedAndTheSceneRecovers) {
  // The issue: a 3 cm jump in one step gave a 19.7 N spike and left the scene inverted and
  // stuck. Now: at most the device limit, the watchdog's events, and after withdrawing the
  // scene is back at rest and a new press feels like a fresh scene's.
  for (const char* id : kAll) {
    Scene s = make(id);
    const Site w = site(s);
    const double limit = s.config().contact.force_limit;
    Track r;
    step(s, w.p + 0.002 * w.n, r);
    step(s, w.p - 0.03 * w.n, r);  // 3.2 cm in one step
    for (int i = 0; i < 100; ++i) step(s, w.p - 0.03 * w.n, r);
    ASSERT_TRUE(r.finite()) << id;
    EXPECT_LE(r.fmax(), limit + 1e-12) << id;
    EXPECT_GT(r.F[1].dot(w.n), 0.0) << id;  // pushes back out from the first step
    EXPECT_GE(r.count(EventKind::force_limited) + r.count(EventKind::divergence), 1) << id;
    for (int i = 0; i < 1000; ++i) step(s, w.p + 0.01 * w.n, r);  // withdraw and rest 1 s
    EXPECT_FALSE(r.contact.back()) << id;
    EXPECT_LT(s.stats().max_rest_error, 1e-4) << id;
    // The same slow press on the recovered scene and on a fresh one.
    Scene fresh = make(id);
    Track a, b;
    for (int i = 0; i <= 400; ++i) {
      const Eigen::Vector3d x = w.p - (-0.001 + 1e-5 * i) * w.n;
      step(s, x, a);
      step(fresh, x, b);
    }
    EXPECT_NEAR(a.F.back().norm(), b.F.back().norm(), 0.02 * b.F.back().norm() + 1e-3) << id;
  }
}

TEST(ContactHard, StiffTissueTenThousandTimesAtOneMillisecond) {
  // 10^4 x the stiffness at h = 1 ms: the deformable models' tissue (Young's modulus), the
  // rigid ones' contact (A; B with its ring steps scaled so m1 k <= 1 still holds). A slow press
  // then a release: no NaN, force <= the limit (logged), and at rest no force is left.
  for (const char* id : kAll) {
    Scene s = make(id, [](SceneConfig& c) {
      if (c.model == "penalty" || c.model == "ring") {
        c.contact.stiffness *= 1e4;
        c.ring.m1 /= 1e4;
        c.ring.m2 /= 1e4;
        c.ring.m3 /= 1e4;
      } else {
        c.material.youngs_modulus = 1e4 * c.material.youngs_modulus.value_or(1e5);
      }
    });
    const Site w = site(s);
    Track r;
    for (int i = 0; i <= 1100; ++i) step(s, w.p - (-0.001 + 1e-5 * i) * w.n, r);  // to 1 cm
    for (int i = 0; i <= 1100; ++i) step(s, w.p - (0.01 - 1e-5 * i) * w.n, r);    // back out
    for (int i = 0; i < 500; ++i) step(s, w.p + 0.002 * w.n, r);                  // rest
    ASSERT_TRUE(r.finite()) << id;
    EXPECT_LE(r.fmax(), s.config().contact.force_limit + 1e-12) << id;
    EXPECT_GE(r.count(EventKind::force_limited), 1) << id;  // 1 cm into 10^4 x stiff tissue
    EXPECT_EQ(r.F.back().norm(), 0.0) << id;
    EXPECT_LT(s.stats().max_rest_error, 1e-4) << id;
  }
}

namespace {

// Prototype `id` with its mesh replaced by a file (path relative to the prototype file).
std::string with_mesh_file(const std::string& id, const std::string& file, const std::string& dir) {
  std::ifstream in(proto(id));
  std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto a = s.find("\"mesh\":"), b = s.find('}', a);
  s.replace(a, b - a + 1, "\"mesh\": {\"file\": \"" + file + "\"}");
  const std::string p = dir + "/" + id + "_" + file + ".json";
  std::ofstream(p) << s;
  return p;
}

}  // namespace

TEST(ContactHard, InvertedTetInTheInput) {
  // A tet mesh with the tet nearest the press point inverted (two vertices swapped): either the
  // file is refused with its location, or the scene runs bounded and returns to rest.
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "palplab_test_contact_tets";
  fs::create_directories(dir);
  mesh::TetMesh tm = mesh::generate_model_c(0, 1600);
  // The tets nearest the body's press point.
  Scene ref = make("C");
  const Site w = site(ref);
  std::vector<std::pair<double, int>> near;
  for (long t = 0; t < tm.T.rows(); ++t) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) c += tm.V.row(tm.T(t, k)).transpose() / 4.0;
    near.push_back({(c - w.p).norm(), static_cast<int>(t)});
  }
  std::sort(near.begin(), near.end());
  std::swap(tm.T(near[0].second, 0), tm.T(near[0].second, 1));  // inverted
  mesh::write_tetgen((dir / "bad").string(), tm);
  for (const char* id : {"C", "D"}) {
    const std::string p = with_mesh_file(id, "bad.node", dir.string());
    try {
      Scene s = prototypes::build_scene(p);
      Track r;
      for (int i = 0; i <= 600; ++i) step(s, w.p - (-0.002 + 1e-5 * i) * w.n, r);
      for (int i = 0; i < 1000; ++i) step(s, w.p + 0.01 * w.n, r);
      std::printf("%s: built; fmax %.3f, divergences %ld, rest error %.3g\n", id, r.fmax(),
                  s.stats().divergences, s.stats().max_rest_error);
      EXPECT_TRUE(r.finite()) << id;
      EXPECT_LE(r.fmax(), s.config().contact.force_limit + 1e-12) << id;
      EXPECT_LT(s.stats().max_rest_error, 1e-4) << id;
    } catch (const InputError& e) {
      // D refuses it (measured: "fem: tet 5172: inverted tetrahedron"; the message names the tet
      // but not the file: engine/models/fem_*, reported to its owner). C builds it and stays
      // bounded, which the branch above checks (measured: 0.95 N peak, back at rest).
      std::printf("%s: refused: %s\n", id, e.what());
      EXPECT_EQ(std::string(id), "D");
      EXPECT_NE(std::string(e.what()).find("inverted"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(std::to_string(near[0].second)), std::string::npos)
          << e.what();
    }
  }
}
