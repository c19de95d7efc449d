// Physics that does not depend on the mesh (issue: engine). The press force of a mass-spring
// prototype comes from the material (E, density, foundation per area) and the probe's face,
// so the same press on three resolutions of the organ gives the same stiffness; refinement
// keeps the force and the mass; C1 and C2 differ in what they draw, not in what the hand
// feels; prototype B never shows more displacement than the penetration it renders.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "engine/haptics/clock.hpp"
#include "engine/haptics/press.hpp"
#include "prototypes/factory.hpp"
#include "tests/prototypes/probe_points.hpp"
#include "tests/prototypes/prototype_text.hpp"

using namespace palplab;
using namespace palplab::engine;
using palplab::engine::testing::proto;
using palplab::engine::testing::read;

namespace {

std::string variant(std::string text, const std::string& name,
                    const std::vector<std::pair<std::string, std::string>>& edits) {
  return palplab::engine::testing::variant_file(std::move(text), "physics_" + name, edits);
}

struct PressResult {
  double k1 = 0, k25 = 0;  // N/m: secant stiffness of the device at 1 N and 2.5 N
  double mass0 = 0, mass_loaded = 0, mass_after = 0;
  long new_nodes = 0, faces_loaded = 0;
  double max_excess = -1;  // m: largest visible deformation minus device penetration
};

// The one press script at the surface node nearest `point` (the same physical place on every
// mesh), to 2.5 N, held 0.2 s.
PressResult press_near(const std::string& path, const Eigen::Vector3d& point) {
  Scene s = prototypes::build_scene(path);
  const SceneGeometry& g = s.geometry();
  const int node = g.nearest_node(point);
  PressDevice d(press_at(g, node, 2.5, 0.2, 0.2));
  PressResult r;
  r.mass0 = s.stats().total_mass;
  double d0 = -1;
  bool loaded = false;
  LockstepOptions o;
  o.duration = 1e6;
  o.frame_period = 0;
  run_lockstep(s, d, o, [&](const Rendered& x, const Sample&) {
    const double f = x.force.norm();
    if (f > 0 && d0 < 0) d0 = d.depth();
    if (d.phase() == PressPhase::approach && d0 >= 0) {
      if (f < 1.0) r.k1 = f / std::max(d.depth() - d0, 1e-9);
      if (f < 2.5) r.k25 = f / std::max(d.depth() - d0, 1e-9);
    }
    // Penetration rendered by a penalty contact: |F| / k (prototype B's contact stiffness).
    if (x.contact) r.max_excess = std::max(r.max_excess, x.visible_deformation - f / 500.0);
    if (!loaded && d.phase() == PressPhase::withdraw) {
      loaded = true;
      const SceneStats st = s.stats();
      r.mass_loaded = st.total_mass;
      RowMatX3d V;
      RowMatX3i F;
      s.current_surface(V, F);
      r.faces_loaded = F.rows();
    }
  });
  EXPECT_TRUE(d.force_reached()) << path;
  const SceneStats st = s.stats();
  r.mass_after = st.total_mass;
  r.new_nodes = st.new_nodes_max;
  return r;
}

using palplab::engine::testing::kBody;
using palplab::engine::testing::kOvary;

void expect_within(const std::vector<double>& k, double rel, const std::string& what) {
  double lo = k[0], hi = k[0], mean = 0;
  for (double x : k) {
    lo = std::min(lo, x);
    hi = std::max(hi, x);
    mean += x / k.size();
  }
  EXPECT_LT(hi - mean, rel * mean) << what << ": " << lo << " .. " << hi << " N/m";
  EXPECT_LT(mean - lo, rel * mean) << what << ": " << lo << " .. " << hi << " N/m";
  std::printf("%s: %.1f .. %.1f N/m (mean %.1f, spread %+.1f%% / %+.1f%%)\n", what.c_str(), lo, hi,
              mean, 100 * (lo - mean) / mean, 100 * (hi - mean) / mean);
}

}  // namespace

TEST(Physics, StiffnessOfPrototypeCDoesNotDependOnTheMesh) {
  // Model-C at three resolutions (1689, 2426, 4565 nodes), refinement off: the press force is
  // within the force Weber fraction (7 %) at the ovary and at the body (measured +-2.3 %).
  const std::string c = read(proto("C"));
  for (const auto& [where, point] : {std::pair{"ovary", kOvary}, std::pair{"body", kBody}}) {
    std::vector<double> k;
    for (const char* v : {"1200", "1600", "2440"}) {
      const std::string path =
          variant(c, std::string("res_") + v,
                  {{"\"vertices\": 1600", std::string("\"vertices\": ") + v},
                   {"\"enabled\": true, \"policy\"", "\"enabled\": false, \"policy\""}});
      k.push_back(press_near(path, point).k25);
    }
    expect_within(k, 0.07, std::string("C at 2.5 N, ") + where);
  }
}

TEST(Physics, RefinementKeepsTheForceAndConservesTheMass) {
  // The three organ models: Model-C (tetrahedral) and the Model-A (1500) and Model-B (6000)
  // tract surfaces as membranes, each at the ovary and at the body. Refinement on vs off:
  // stiffness within 7 %, mass exact. At C's body the coarse edges (12.9 mm) are longer than the
  // probe face's radius and refinement adds ~260 nodes under it: before the refined tets were
  // re-divided (refinement.hpp) the new nodes had no volume stiffness and the press was 39 %
  // soft there (331 vs 540 N/m), which the ovary-only test missed. With the dent ties
  // (refinement.hpp) C's body is 603 vs 540 N/m: +11.7 % over the unrefined press, within 7 % of
  // the two's mean (expect_within's measure) — the vertex pads' coarse single-node press, see
  // test_refine_pad.cpp.
  // (The 192-node stomach is not among them: its edges are longer than the 1 cm probe face, so
  // refining it changes the force by 23 % — a coarse mesh that cannot resolve the probe. Nor is
  // the Model-A membrane at the body: 257 N/m refined vs 188 unrefined at 2.5 N (+37 %; with the
  // disc pad -40 %, -9 %, 0 % at 1, 2.5, 4 N): its unrefined 1500-vertex surface is the
  // outlier there, the refined one is near a 6000-vertex surface's press
  // (MembraneAtTheBodyTheUnrefinedCoarseMeshIsTheOutlier, test_refine_pad.cpp).)
  const std::string c = read(proto("C"));
  const std::string membrane_tract =
      variant(c, "tract_surface_base",
              {{"\"generator\": \"model_c\", \"vertices\": 1600",
                "\"generator\": \"tract\", \"vertices\": 1500"},
               {"\"rayleigh_beta\"", "\"thickness\": 0.01, \"rayleigh_beta\""}});
  const std::string model_b_surface =
      variant(c, "tract6000_surface_base",
              {{"\"generator\": \"model_c\", \"vertices\": 1600",
                "\"generator\": \"tract\", \"vertices\": 6000"},
               {"\"rayleigh_beta\"", "\"thickness\": 0.01, \"rayleigh_beta\""},
               {"\"threshold_area\": 4e-6", "\"threshold_area\": 1e-6"}});
  struct Case {
    std::string name, text;
    Eigen::Vector3d point;
  };
  for (const Case& k : {Case{"tet tract, ovary", c, kOvary}, Case{"tet tract, body", c, kBody},
                        Case{"Model-A surface, ovary", read(membrane_tract), kOvary},
                        Case{"Model-B surface, ovary", read(model_b_surface), kOvary},
                        Case{"Model-B surface, body", read(model_b_surface), kBody}}) {
    const std::string on = variant(k.text, "on", {});
    const std::string off = variant(
        k.text, "off", {{"\"enabled\": true, \"policy\"", "\"enabled\": false, \"policy\""}});
    const PressResult a = press_near(on, k.point), b = press_near(off, k.point);
    EXPECT_GT(a.new_nodes, 0) << k.name;
    EXPECT_EQ(b.new_nodes, 0) << k.name;
    expect_within({a.k25, b.k25}, 0.07, k.name + ": refinement on/off");
    EXPECT_NEAR(a.mass_loaded, a.mass0, 1e-12 * a.mass0) << k.name;
    EXPECT_NEAR(a.mass_after, a.mass0, 1e-12 * a.mass0) << k.name;
  }
}

TEST(Physics, C1AndC2DifferInWhatTheyDrawNotInWhatTheHandFeels) {
  // Experiment 4 compares the extent of the visual cue: C2 refines down to half C1's area, so
  // under the same press it draws a finer dent (more new nodes, more faces); the force on the
  // hand stays within the Weber fraction.
  const PressResult c1 = press_near(proto("C1"), kOvary), c2 = press_near(proto("C2"), kOvary);
  EXPECT_GT(c2.new_nodes, c1.new_nodes);
  EXPECT_GT(c2.faces_loaded, c1.faces_loaded);
  expect_within({c1.k25, c2.k25}, 0.07, "C1 vs C2");
  std::printf("C1: %ld new nodes, %ld faces; C2: %ld new nodes, %ld faces\n", c1.new_nodes,
              c1.faces_loaded, c2.new_nodes, c2.faces_loaded);
}

TEST(Physics, RingModelNeverShowsMoreThanThePenetration) {
  // Prototype B (contact stiffness 500 N/m): the touched node is displaced by m1 F = F / k, the
  // penetration it renders, never more (it was 2x: 10 mm shown for a 5 mm push).
  ASSERT_NE(read(proto("B")).find("\"stiffness\": 500.0"), std::string::npos);
  const PressResult b = press_near(proto("B"), kOvary);
  EXPECT_LE(b.max_excess, 1e-9);
  EXPECT_GE(b.max_excess, -1e-9);  // and it does show all of it
}
