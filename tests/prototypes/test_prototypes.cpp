// Prototype files and the Scene they build: every shipped file builds, bad files give located
// errors, overrides switch cues, lock-step runs are bit-identical, reset() restores the start.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "common/input_error.hpp"
#include "engine/mesh/generate.hpp"
#include "engine/mesh/io.hpp"
#include "prototypes/factory.hpp"
#include "tests/prototypes/press_run.hpp"
#include "tests/prototypes/prototype_text.hpp"

using namespace palplab;
using namespace palplab::engine;
using palplab::engine::testing::depth_press;
using palplab::engine::testing::Rec;
using palplab::engine::testing::run_press;

namespace {

using palplab::engine::testing::proto;

std::string write_temp(const std::string& name, const std::string& text) {
  const auto p = std::filesystem::temp_directory_path() / ("palplab_test_" + name);
  std::ofstream(p) << text;
  return p.string();
}

// Replaces the first occurrence of `from` in prototype `id` and writes it to a temp file.
std::string mutated(const std::string& id, const std::string& from, const std::string& to) {
  std::ifstream in(proto(id));
  std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto k = s.find(from);
  EXPECT_NE(k, std::string::npos) << from;
  s.replace(k, from.size(), to);
  return write_temp(id + "_mut.json", s);
}

// 1-based line of the first occurrence of `needle` in a file.
int line_of(const std::string& path, const std::string& needle) {
  std::ifstream in(path);
  std::string line;
  for (int k = 1; std::getline(in, line); ++k)
    if (line.find(needle) != std::string::npos) return k;
  return -1;
}

std::string error_of(const std::string& path) {
  try {
    prototypes::build_scene(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// The press of these tests: in to 8 mm at 2 cm/s, held 0.4 s, out at 3 cm/s (`steps` steps).
std::vector<Rec> press(Scene& s, const std::string& region, int steps = 1500) {
  return run_press(s, depth_press(s, region, 0.008, 0.4, 0.03), steps);
}

}  // namespace

TEST(Prototypes, EveryShippedFileBuilds) {
  for (const char* id : {"A", "B", "C", "C1", "C2"}) {
    Scene s = prototypes::build_scene(proto(id));
    EXPECT_EQ(s.prototype(), id);
    EXPECT_EQ(s.dt(), 1e-3);
    const auto& g = s.geometry();
    EXPECT_GT(g.V.rows(), 1000);
    EXPECT_EQ(g.N.rows(), g.V.rows());
    EXPECT_EQ(static_cast<long>(g.vertex_region.size()), g.V.rows());
    EXPECT_GE(g.region_index("ovary_left"), 0);
    EXPECT_GE(g.region_node("ovary_left"), 0);
    const auto sum = prototypes::inspect_prototype(proto(id));
    EXPECT_EQ(sum.id, id);
    EXPECT_EQ(sum.region_names, g.region_names);
  }
  // the original work table: mesh sizes and C2 = half of C1's threshold area.
  EXPECT_NEAR(prototypes::build_scene(proto("A")).geometry().V.rows(), 1500, 30);
  EXPECT_NEAR(prototypes::build_scene(proto("B")).geometry().V.rows(), 6000, 120);
  const auto c1 = prototypes::load_prototype(proto("C1")),
             c2 = prototypes::load_prototype(proto("C2"));
  EXPECT_DOUBLE_EQ(c2.refinement.params.threshold_area, 0.5 * c1.refinement.params.threshold_area);
}

TEST(Prototypes, PressRendersWhatEachPrototypeShows) {
  for (const char* id : {"A", "B", "C"}) {
    Scene s = prototypes::build_scene(proto(id));
    const auto r = press(s, "ovary_left");
    double fmax = 0, dmax = 0;
    bool audio = false, start = false, end = false;
    for (const auto& x : r) {
      fmax = std::max(fmax, x.force.norm());
      dmax = std::max(dmax, x.visible_deformation);
      audio |= x.audio;
      for (const auto& e : x.ev) {
        start |= e.kind == EventKind::contact_start;
        end |= e.kind == EventKind::contact_end;
      }
      if (x.contact) {
        EXPECT_EQ(s.geometry().region_names[x.contact_region], "ovary_left")
            << x.t << " node " << x.contact_node;
      }
    }
    EXPECT_GT(fmax, 2.0) << id;
    EXPECT_TRUE(start && end) << id;
    EXPECT_EQ(audio, std::string(id) == "A") << id;  // only A has the sound cue
    if (std::string(id) == "A") {
      EXPECT_EQ(dmax, 0.0);
    } else {
      EXPECT_GT(dmax, 1e-3) << id;
    }
    EXPECT_FALSE(r.back().contact);
  }
}

TEST(Prototypes, OverridesSwitchCuesAndThresholds) {
  SceneOverrides ov;
  ov.audio = false;
  ov.visual_deformation = false;
  ov.thresholds["ovary_left"] = Thresholds{0.5, 0.8, 1.0};
  for (const char* id : {"A", "C"}) {
    Scene s = prototypes::build_scene(proto(id), ov);
    bool st = false;
    for (const auto& x : press(s, "ovary_left")) {
      EXPECT_FALSE(x.audio);
      EXPECT_EQ(x.visible_deformation, 0.0);
      for (const auto& e : x.ev)
        if (e.kind == EventKind::st_reached) {
          st = true;
          EXPECT_NEAR(e.value, 0.5, 0.05);  // crossed at the overridden ST
        }
    }
    EXPECT_TRUE(st);
  }
  SceneOverrides haptic_off;
  haptic_off.haptic = false;
  Scene s = prototypes::build_scene(proto("B"), haptic_off);
  for (const auto& x : press(s, "ovary_left")) EXPECT_EQ(x.force.norm(), 0.0);
  SceneOverrides bad;
  bad.thresholds["liver"] = Thresholds{1, 2, 3};
  EXPECT_THROW(prototypes::build_scene(proto("A"), bad), InputError);
}

TEST(Prototypes, LockStepIsBitIdenticalAcrossRunsAndReset) {
  for (const char* id : {"B", "C2"}) {
    Scene a = prototypes::build_scene(proto(id));
    Scene b = prototypes::build_scene(proto(id));
    const auto ra = press(a, "ovary_right", 1200);
    const auto rb = press(b, "ovary_right", 1200);
    a.reset();
    const auto rc = press(a, "ovary_right", 1200);
    ASSERT_EQ(ra.size(), rb.size());
    for (size_t k = 0; k < ra.size(); ++k) {
      ASSERT_EQ(std::memcmp(ra[k].force.data(), rb[k].force.data(), sizeof(double) * 3), 0) << k;
      ASSERT_EQ(std::memcmp(ra[k].force.data(), rc[k].force.data(), sizeof(double) * 3), 0) << k;
      ASSERT_EQ(ra[k].visible_deformation, rb[k].visible_deformation);
      ASSERT_EQ(ra[k].visible_deformation, rc[k].visible_deformation);
      ASSERT_EQ(ra[k].contact_node, rc[k].contact_node);
      ASSERT_EQ(ra[k].ev.size(), rc[k].ev.size());
      for (size_t e = 0; e < ra[k].ev.size(); ++e) {
        ASSERT_EQ(ra[k].ev[e].kind, rb[k].ev[e].kind);
        ASSERT_EQ(ra[k].ev[e].value, rb[k].ev[e].value);
      }
    }
  }
}

TEST(Prototypes, MassConservedAndRestoredThroughRefinement) {
  Scene s = prototypes::build_scene(proto("C2"));
  const double m0 = s.stats().total_mass;
  // 2 mm out to 18 mm in at 5 cm/s, held to 0.6 s; then out at 5 cm/s and left 2 mm outside.
  PressSpec spec = depth_press(s, "body", 0.018, 0.2);
  spec.approach_speed = 0.05;
  PressDevice press(spec);
  long max_new = 0;
  bool mass_kept = true;
  run_lockstep(s, press, {.duration = 0.6, .frame_period = 0.0},
               [&](const Rendered&, const Sample&) {
                 const auto st = s.stats();
                 max_new = std::max(max_new, st.nodes - st.coarse_nodes);
                 mass_kept = mass_kept && std::abs(st.total_mass - m0) <= 1e-12 * m0;
               });
  EXPECT_TRUE(mass_kept);
  EXPECT_GT(max_new, 0);  // refined while pressing
  run_lockstep(s, press, {.duration = 1.5, .frame_period = 0.0},
               [&](const Rendered&, const Sample&) {
                 mass_kept = mass_kept && std::abs(s.stats().total_mass - m0) <= 1e-12 * m0;
               });
  EXPECT_TRUE(mass_kept);
  EXPECT_EQ(press.phase(), PressPhase::release);  // back outside, at rest
  const auto st = s.stats();
  EXPECT_EQ(st.nodes, st.coarse_nodes);  // simplified after release
  EXPECT_EQ(st.total_mass, m0);
  EXPECT_LT(st.max_rest_error, 1e-5);
  EXPECT_FALSE(st.nan_detected);
}

TEST(Prototypes, BadFilesGiveLocatedErrors) {
  // Syntax error: line and column.
  const std::string syn =
      write_temp("syntax.json",
                 "{\n  \"format\": \"palplab-prototype/1\",\n  \"id\": \"X\" \"mesh\": {}\n}\n");
  std::string e = error_of(syn);
  EXPECT_NE(e.find(syn + ":3:"), std::string::npos) << e;
  // Unknown key, located at the key, with the JSON path.
  e = error_of(mutated("B", "\"scope\": \"rings\"", "\"scop\": \"rings\""));
  EXPECT_NE(e.find(":" + std::to_string(line_of(proto("B"), "\"scope\"")) + ":"), std::string::npos)
      << e;
  EXPECT_NE(e.find("$.model.scop"), std::string::npos) << e;
  // The id follows the ids' grammar (review finding 2026-12-06: an escape sequence in it reached
  // the terminal through `probe`, "A/B" was accepted).
  e = error_of(mutated("A", "\"id\": \"A\"", "\"id\": \"A\\u001b[2J\""));
  EXPECT_NE(e.find("$.id: expected an id of 1 to 64 ASCII letters"), std::string::npos) << e;
  EXPECT_NE(e.find("U+001B at character 2"), std::string::npos) << e;
  EXPECT_EQ(e.find('\x1b'), std::string::npos) << e;
  e = error_of(mutated("A", "\"id\": \"A\"", "\"id\": \"A/B\""));
  EXPECT_NE(e.find("'/' (U+002F) at character 2"), std::string::npos) << e;
  // Out-of-range value.
  e = error_of(mutated("A", "\"stiffness\": 500.0", "\"stiffness\": -3"));
  EXPECT_NE(e.find("$.contact.stiffness"), std::string::npos) << e;
  EXPECT_NE(e.find("out of range"), std::string::npos) << e;
  // Semantic rule: |m1| > |m2| > |m3|.
  e = error_of(mutated("B", "\"m1\": 0.002", "\"m1\": 0.001"));
  EXPECT_NE(e.find("|m1| > |m2| > |m3|"), std::string::npos) << e;
  // The touched node may not be shown deeper than the penetration rendered (m1 k <= 1).
  e = error_of(mutated("B", "\"m1\": 0.002", "\"m1\": 0.004"));
  EXPECT_NE(e.find("$.model.m1"), std::string::npos) << e;
  EXPECT_NE(e.find("penetration"), std::string::npos) << e;
  // ST must be below SFT; unknown region in thresholds; unknown integrator.
  e = error_of(mutated("A", "\"ST\": 2.0", "\"ST\": 4.0"));
  EXPECT_NE(e.find("must be below SFT"), std::string::npos) << e;
  EXPECT_NE(e.find("$.thresholds[\"*\"].ST"), std::string::npos) << e;
  // The study spelling only: a lower-case cue name is a typo.
  e = error_of(mutated("A", "\"ST\": 2.0", "\"st\": 2.0"));
  EXPECT_NE(e.find("unknown"), std::string::npos) << e;
  e = error_of(mutated("A", "\"*\":", "\"liver\":"));
  EXPECT_NE(e.find("$.thresholds.liver"), std::string::npos) << e;
  e = error_of(mutated("C", "\"backward_euler\"", "\"forward_euler\""));
  EXPECT_NE(e.find("$.model.integrator"), std::string::npos) << e;
  EXPECT_NE(e.find(":" + std::to_string(line_of(proto("C"), "\"integrator\"")) + ":"),
            std::string::npos)
      << e;
  // Wrong type, missing required key, missing file.
  e = error_of(mutated("C", "\"rayleigh_beta\": 0.002", "\"rayleigh_beta\": \"heavy\""));
  EXPECT_NE(e.find("$.model.rayleigh_beta"), std::string::npos) << e;
  // Stiffness per spring is not a prototype parameter any more: it comes from the material.
  e = error_of(mutated("C", "\"rayleigh_beta\": 0.002", "\"stiffness\": 150.0"));
  EXPECT_NE(e.find("unknown key \"stiffness\""), std::string::npos) << e;
  e = error_of(mutated("C", "\"material\": {\"tissue\": \"soft tissue\"",
                       "\"material\": {\"tissue\": \"jelly\""));
  EXPECT_NE(e.find("$.model.material"), std::string::npos) << e;
  e = error_of(mutated("A", "\"id\": \"A\",", ""));
  EXPECT_NE(e.find("missing required key \"id\""), std::string::npos) << e;
  EXPECT_NE(error_of("/nonexistent/X.json").find("/nonexistent/X.json"), std::string::npos);
}

TEST(Prototypes, ProxyDoesNotSlipThroughThinParts) {
  // Push straight through a horn (a tube about 2-3 cm across) to 4 cm: a nearest-node contact
  // would jump to the far wall half way and flip the force; the proxy keeps the near wall.
  Scene s = prototypes::build_scene(proto("A"));
  const auto& g = s.geometry();
  const PressSpec spec = depth_press(s, "horn_left", 0.04, 1e3);  // to 4 cm at 2 cm/s
  const Eigen::Vector3d p = spec.point, n = spec.normal;
  std::vector<std::pair<double, Rendered>> steps;  // (depth of the device, what it rendered)
  PressDevice press(spec);
  run_lockstep(s, press, {.duration = 2.101, .frame_period = 0.0},
               [&](const Rendered& r, const Sample& x) {
                 steps.push_back({n.dot(p - x.x), r});
               });
  ASSERT_EQ(steps.size(), 2101u);
  double last = 0.0, at15mm = 0.0;
  for (const auto& [depth, r] : steps) {
    if (depth <= 0.0) continue;
    if (std::abs(depth - 0.015) < 1e-9) at15mm = r.force.norm();
    ASSERT_TRUE(r.contact) << depth;
    ASSERT_GT(g.N.row(r.contact_node).dot(n.transpose()), 0.5)
        << "jumped to the far side at " << depth;
    ASSERT_GE(r.force.norm(), last - 1e-9) << depth;  // keeps growing with depth
    ASSERT_GT(r.force.dot(n), 0.0);                   // and keeps pushing the hand out
    last = r.force.norm();
  }
  EXPECT_NEAR(steps.back().first, 0.04, 1e-12);
  EXPECT_NEAR(at15mm, 500.0 * 0.015, 0.3);  // Hooke: 500 N/m x 1.5 cm
  EXPECT_NEAR(last, 8.5, 1e-9);             // 20 N at 4 cm, clamped to the device's 8.5 N
  // The scenario is a real thin part: at 4 cm the nearest surface node faces the other way.
  const Eigen::Vector3d deep = p - 0.04 * n;
  EXPECT_LT(g.N.row(g.nearest_node(deep)).dot(n.transpose()), 0.0);
}

TEST(Prototypes, MeshFilesInsteadOfGenerators) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "palplab_test_meshfile";
  fs::create_directories(dir);
  // A surface (OBJ with region groups) and a tet mesh (TetGen files) written by the mesh module.
  palplab::mesh::write_obj((dir / "tract.obj").string(), palplab::mesh::generate_tract({1500, 0}));
  palplab::mesh::write_tetgen((dir / "tract_c").string(), palplab::mesh::generate_model_c(0, 2489));
  auto with_mesh = [&](const std::string& id, const std::string& mesh_json) {
    std::ifstream in(proto(id));
    std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto a = s.find("\"mesh\":"), b = s.find('}', a);
    s.replace(a, b - a + 1, "\"mesh\": " + mesh_json);
    const fs::path p = dir / (id + "_file.json");
    std::ofstream(p) << s;
    return p.string();
  };
  // Relative paths are relative to the prototype file.
  Scene a = prototypes::build_scene(with_mesh("A", "{\"file\": \"tract.obj\"}"));
  EXPECT_EQ(a.geometry().V.rows(), prototypes::build_scene(proto("A")).geometry().V.rows());
  EXPECT_GE(a.geometry().region_index("ovary_left"), 0);
  double fmax = 0;
  for (const auto& r : press(a, "ovary_left")) fmax = std::max(fmax, r.force.norm());
  EXPECT_GT(fmax, 2.0);
  Scene c = prototypes::build_scene(with_mesh("C", "{\"file\": \"tract_c.node\"}"));
  EXPECT_GT(c.stats().springs, 10000);  // tet edges
  EXPECT_EQ(
      prototypes::inspect_prototype(with_mesh("C", "{\"file\": \"tract_c.node\"}")).region_names,
      c.geometry().region_names);
  // Errors: missing file (located at $.mesh.file), both keys, generator-only keys, bad content.
  std::string e = error_of(with_mesh("A", "{\"file\": \"nope.obj\"}"));
  EXPECT_NE(e.find("$.mesh.file"), std::string::npos) << e;
  e = error_of(with_mesh("A", "{\"file\": \"tract.obj\", \"generator\": \"tract\"}"));
  EXPECT_NE(e.find("not both"), std::string::npos) << e;
  e = error_of(with_mesh("A", "{\"file\": \"tract.obj\", \"vertices\": 10}"));
  EXPECT_NE(e.find("$.mesh.vertices"), std::string::npos) << e;
  // Each generator's own vertex range, at the JSON path (model_c refused 12 only when building,
  // as "tract: --vertices ..."); the stomach is one fixed mesh (its "vertices" was ignored).
  e = error_of(with_mesh("C", "{\"generator\": \"model_c\", \"vertices\": 12}"));
  EXPECT_NE(e.find("$.mesh.vertices"), std::string::npos) << e;
  EXPECT_NE(e.find("model_c"), std::string::npos) << e;
  EXPECT_EQ(e.find("--vertices"), std::string::npos) << e;
  e = error_of(with_mesh("A", "{\"generator\": \"stomach\", \"vertices\": 500}"));
  EXPECT_NE(e.find("$.mesh.vertices"), std::string::npos) << e;
  EXPECT_NE(e.find("stomach"), std::string::npos) << e;
  e = error_of(with_mesh("A", "{\"generator\": \"shoulder\", \"vertices\": 100}"));
  EXPECT_NE(e.find("$.mesh.vertices"), std::string::npos) << e;
  std::ofstream(dir / "broken.obj") << "v 0 0 0\nv 1 0 0\nf 1 2 7\n";
  e = error_of(with_mesh("A", "{\"file\": \"broken.obj\"}"));
  EXPECT_NE(e.find("broken.obj"), std::string::npos) << e;
}

// The event log's touches: contacts separated by less than kTouchGap are one touch (a hand
// resting on the surface lost and regained a contact of a few mN step by step: 9 500 contact
// events in nine 50 s sessions of exp2, review 2026-12-07). The contact the participant
// perceives (Rendered::contact) is the physics' own, unchanged.
TEST(Prototypes, ContactsSeparatedByLessThanTheTouchGapAreOneTouch) {
  Scene s = prototypes::build_scene(proto("A"));
  const SceneGeometry& g = s.geometry();
  const int node = g.region_node("ovary_left");
  const Eigen::Vector3d n = g.N.row(node).transpose(), p = g.V.row(node).transpose();
  const Eigen::Vector3d out = p + 0.002 * n, in = p - 0.001 * n;
  for (int k = 1; k <= 200; ++k) s.step(g.start_position + (out - g.start_position) * k / 200.0);
  struct Step {
    double t;
    bool contact;
    std::vector<Event> ev;
  };
  std::vector<Step> log;
  auto run = [&](const Eigen::Vector3d& x, int steps) {
    for (int k = 0; k < steps; ++k) {
      const Rendered r = s.step(x);
      log.push_back({r.t, r.contact, {r.events.begin(), r.events.end()}});
    }
  };
  // touch 1: in 5, a 2-step lift, in 5; a lift of 30 steps; touch 2: in 5, lifted 30; touch 3
  // after a lift of exactly kTouchGap (10 steps without contact: a new touch), lifted 30.
  run(in, 5);
  run(out, 2);
  run(in, 5);
  run(out, 30);
  run(in, 5);
  run(out, 10);
  run(in, 5);
  run(out, 30);
  ASSERT_EQ(log.size(), 92u);
  EXPECT_TRUE(log[0].contact);
  EXPECT_FALSE(log[5].contact);  // the physics lost the contact in the short lift
  EXPECT_TRUE(log[7].contact);
  std::vector<std::pair<std::size_t, Event>> touches;  // (step logged at, event)
  for (std::size_t i = 0; i < log.size(); ++i)
    for (const Event& e : log[i].ev)
      if (e.kind == EventKind::contact_start || e.kind == EventKind::contact_end)
        touches.push_back({i, e});
  ASSERT_EQ(touches.size(), 6u);
  EXPECT_EQ(touches[0].second.kind, EventKind::contact_start);
  EXPECT_EQ(touches[0].first, 0u);
  // The end carries the lift's time (step 12, the first of the long lift) and is logged once
  // the contact has stayed lost for kTouchGap.
  EXPECT_EQ(touches[1].second.kind, EventKind::contact_end);
  EXPECT_DOUBLE_EQ(touches[1].second.t, log[12].t);
  EXPECT_NEAR(log[touches[1].first].t - log[12].t, kTouchGap - s.dt(), 1e-9);
  EXPECT_GT(touches[1].second.value, 0.0);  // the touch's peak force
  EXPECT_EQ(touches[2].second.kind, EventKind::contact_start);
  EXPECT_EQ(touches[2].first, 42u);
  EXPECT_EQ(touches[3].second.kind, EventKind::contact_end);
  EXPECT_DOUBLE_EQ(touches[3].second.t, log[47].t);
  EXPECT_EQ(touches[4].second.kind, EventKind::contact_start);
  EXPECT_EQ(touches[4].first, 57u);
  EXPECT_EQ(touches[5].second.kind, EventKind::contact_end);
  EXPECT_DOUBLE_EQ(touches[5].second.t, log[62].t);
}

// Rendered::visible_volume (Scene::set_visible_volume): the pushed-in volume of the drawn
// surface, computed at the display's frame rate and held between frames, shown only while the
// deformation is; asking for it changes nothing of the physics (C's lazily written exterior is
// brought up to date for it, bit-identically).
TEST(Prototypes, VisibleVolumeIsTheDrawnSurfacesAtTheFrameRate) {
  for (const char* id : {"B", "C"}) {
    SCOPED_TRACE(id);
    Scene on = prototypes::build_scene(proto(id)), off = prototypes::build_scene(proto(id));
    on.set_visible_volume(true);
    const SceneGeometry& g = on.geometry();
    Eigen::VectorXd area = Eigen::VectorXd::Zero(g.V.rows());  // a third of each face's area
    for (Eigen::Index f = 0; f < g.F.rows(); ++f) {
      const Eigen::Vector3d a = g.V.row(g.F(f, 0)), b = g.V.row(g.F(f, 1)), c = g.V.row(g.F(f, 2));
      for (int k = 0; k < 3; ++k) area[g.F(f, k)] += (b - a).cross(c - a).norm() / 6.0;
    }
    const PressSpec spec = press_at(g, g.region_node("ovary_left"), 2.5, 0.2, 1e3);
    PressDevice d_on(spec), d_off(spec);
    const long frame = std::lround(1.0 / (kVisibleFrameRate * on.dt()));
    double last = -1.0, peak = 0.0;
    int shown = 0;
    for (long k = 1; k <= 1500 && !d_on.finished(); ++k) {
      const Rendered r = on.step(d_on.read(on.time()).position);
      d_on.write(r);
      const Rendered q = off.step(d_off.read(off.time()).position);
      d_off.write(q);
      ASSERT_EQ(r.force, q.force) << k;  // bit for bit
      EXPECT_EQ(q.visible_volume, 0.0);
      if (r.visible_deformation == 0.0) {
        EXPECT_EQ(r.visible_volume, 0.0) << k;
        continue;
      }
      ++shown;
      if ((k - 1) % frame == 0) {
        mesh::Positions V;
        mesh::Faces F;
        on.current_surface(V, F);
        double vol = 0.0;
        for (Eigen::Index i = 0; i < g.V.rows(); ++i)
          vol += area[i] * std::max(0.0, -(V.row(i) - g.V.row(i)).dot(g.N.row(i)));
        EXPECT_NEAR(r.visible_volume, vol, 1e-12 * vol + 1e-18) << k;
        last = r.visible_volume;
      } else if (last >= 0.0) {
        EXPECT_EQ(r.visible_volume, last) << k;  // held between frames
      }
      peak = std::max(peak, r.visible_volume);
    }
    EXPECT_GT(shown, 100);
    // At 2.5 N B's ring dent is a fraction of a cm^3, C's whole ovary moves: several cm^3.
    EXPECT_GT(peak, std::string(id) == "B" ? 2e-8 : 1e-6);
  }
}
