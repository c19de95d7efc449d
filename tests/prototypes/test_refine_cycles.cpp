// Issue 10's hard case "10^5 refine/simplify cycles": the adaptive refinement of prototype C,
// built exactly as the model builds it (mass_spring_adaptive), refined around the nodes of the
// touched patch and simplified again, on a deformed (pressed) state. Each cycle
// runs the real refine_around / simplify (engine/models/refinement.hpp) — the code a contact
// runs when its force crosses the refinement threshold and when it ends; the time integration
// between them (Scene steps) is left out: it does not touch the refinement data and made the
// naive form take ~100 s.
#include <gtest/gtest.h>
#include <malloc.h>

#include <chrono>
#include <cmath>

#include "engine/haptics/scene.hpp"
#include "engine/models/mass_spring_model.hpp"
#include "prototypes/factory.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {

// Elastic energy of the springs and home springs at the state X (J).
double elastic_energy(const MassSpringSystem& s) {
  double e = 0;
  for (long k = 0; k < s.springs.size(); ++k) {
    const double l = (s.X.row(s.springs.E(k, 0)) - s.X.row(s.springs.E(k, 1))).norm();
    e += 0.5 * s.springs.ks[k] * (l - s.springs.rest[k]) * (l - s.springs.rest[k]);
  }
  for (long i = 0; i < s.nodes(); ++i)
    e += 0.5 * s.home_ks[i] * (s.X.row(i) - s.X_rest.row(i)).squaredNorm();
  return e;
}

// `cycles` refine/simplify cycles of prototype C's refinement on the mesh of cfg, around the
// surface nodes within two probe radii of `press` (a surface node), on a pressed state.
void run_cycles(const SceneConfig& cfg, int press, int cycles) {
  ASSERT_TRUE(cfg.refinement.enabled);
  const auto cm = scene_mesh(cfg.mesh);
  AdaptiveMassSpring m = mass_spring_adaptive(cfg, *cm);
  const Eigen::Vector3d p = cm->V.row(press).transpose(), n = cm->N.row(press).transpose();
  // The touched patch: the surface nodes within twice the probe's radius of the press node —
  // the nodes a contact sliding there refines around (C's surface edges at the body are about
  // as long as the probe's radius).
  std::vector<int> patch;
  for (long i = 0; i < cm->V.rows(); ++i)
    if ((cm->V.row(i).transpose() - p).norm() <= 2 * cfg.contact.patch_radius)
      patch.push_back(cm->surface_to_model[i]);
  ASSERT_GE(patch.size(), 5u);
  // A pressed state: 4 mm along -n under the probe, fading out over 2 cm (what refinement
  // carries over: new nodes start at their parents' midpoint).
  MassSpringSystem& s = m.sys;
  for (long i = 0; i < s.nodes(); ++i) {
    const double r = (s.X_rest.row(i).transpose() - p).norm();
    s.X.row(i) = s.X_rest.row(i) - 0.004 * std::exp(-r * r / (0.02 * 0.02)) * n.transpose();
  }
  const MassSpringSystem coarse = s;
  const double M0 = s.mass.sum(), E0 = elastic_energy(s);
  const long nodes0 = s.nodes(), springs0 = s.springs.size(), faces0 = m.F.rows();
  ASSERT_GT(E0, 0);
  long refined = 0, max_nodes = 0;
  double e_lo = INFINITY, e_hi = 0;
  size_t heap_early = 0;
  const int check = 97;  // the O(#springs) checks: every 97th cycle (every patch node in turn)
  const auto t0 = std::chrono::steady_clock::now();
  for (int c = 0; c < cycles; ++c) {
    const int node = patch[c % patch.size()];
    refined += refine_around(m, node, cfg.refinement.params);
    max_nodes = std::max(max_nodes, s.nodes());
    // While refined: the mass is the coarse mass (the refinement redistributes it, 1e-12),
    // nothing is NaN, and the energy of the same state (new nodes at their parents' midpoints)
    // stays near the coarse energy.
    ASSERT_NEAR(s.mass.sum(), M0, 1e-12 * M0) << "cycle " << c;
    if (c % check == 0) {
      ASSERT_TRUE(s.X.allFinite() && s.mass.allFinite()) << "cycle " << c;
      const double e = elastic_energy(s);
      ASSERT_TRUE(std::isfinite(e)) << "cycle " << c;
      e_lo = std::min(e_lo, e / E0);
      e_hi = std::max(e_hi, e / E0);
    }
    simplify(m);
    // Back to the coarse model: counts (no leak of nodes or springs), masses bit for bit, the
    // coarse state untouched, so the energy is the coarse energy again.
    ASSERT_EQ(s.nodes(), nodes0) << "cycle " << c;
    ASSERT_EQ(s.springs.size(), springs0) << "cycle " << c;
    ASSERT_EQ(m.F.rows(), faces0) << "cycle " << c;
    ASSERT_EQ(m.level, 0) << "cycle " << c;
    if (c % check == 0) {
      ASSERT_TRUE((s.mass.array() == coarse.mass.array()).all()) << "cycle " << c;
      ASSERT_TRUE((s.X.array() == coarse.X.array()).all()) << "cycle " << c;
      ASSERT_EQ(elastic_energy(s), E0) << "cycle " << c;
    }
    if (c == cycles / 10) heap_early = mallinfo2().uordblks;
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const size_t heap_end = mallinfo2().uordblks;
  std::printf(
      "%s: %d cycles on %zu patch nodes in %.2f s (%.1f us/cycle); refined %ld times, up to %ld "
      "nodes (coarse %ld); energy while refined %.4f .. %.4f of the coarse; heap %zu -> %zu\n",
      cfg.mesh.key().c_str(), cycles, patch.size(), secs, 1e6 * secs / cycles, refined, max_nodes,
      nodes0, e_lo, e_hi, heap_early, heap_end);
  EXPECT_EQ(refined, cycles);  // every cycle refined (the patch's faces are above A_t)
  EXPECT_GT(max_nodes, nodes0);
  // The same state refined has the energy of its coarse form to a few per cent (midpoints of a
  // smooth field; the membrane shares move to the leaves, refinement.hpp) — never growing.
  EXPECT_GT(e_lo, 0.9);
  EXPECT_LT(e_hi, 1.1);
  // A leak per cycle shows as >= 8 bytes x 4500 cycles = 36 KB; a few KB of one-time allocations
  // (measured 0.3-5 KB, varying between runs: glibc's bookkeeping) are not a leak.
  EXPECT_LE(heap_end, heap_early + 16384) << "heap grew";
}

SceneConfig prototype_c() {
  return prototypes::load_prototype(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/C.json");
}

}  // namespace

// The issue asks for 10^5 cycles inside `make test`; that is not reachable with the current
// refinement: a cycle costs what refine_around and simplify cost — they rebuild the whole
// system (arrays, springs, adjacency, faces: O(#nodes + #springs)) and close the mesh over all
// faces — measured 0.5 ms CPU per cycle on C's 2426-node mesh (50 s CPU for 10^5, 156 s wall on
// the loaded CI machine) and 0.16 ms on the 192-vertex stomach (whose large faces refine into
// ~300 nodes per cycle). Making them incremental (only the touched roots) is the way to 10^5 in
// seconds. So `make test` runs 10^3 cycles on C's own mesh and 5000 on the stomach (C's model
// and refinement; the same code path on a model whose faces all refine deeply), and the full
// 10^5 on C's mesh is the disabled test below (run it with --gtest_also_run_disabled_tests
// --gtest_filter='RefineCycles.*': passes, 156 s).
TEST(RefineCycles, ThousandCyclesOnPrototypeCsOwnMesh) {
  const SceneConfig cfg = prototype_c();
  Scene scene = make_scene(cfg);
  run_cycles(cfg, scene.geometry().region_node("body"), 1000);
}

TEST(RefineCycles, FiveThousandCyclesOnTheStomach) {
  SceneConfig cfg = prototype_c();
  cfg.mesh.generator = "stomach";
  const auto cm = scene_mesh(cfg.mesh);
  int press = 0;  // the surface node of largest x: on the stomach's greater curvature
  for (long i = 0; i < cm->V.rows(); ++i)
    if (cm->V(i, 0) > cm->V(press, 0)) press = static_cast<int>(i);
  run_cycles(cfg, press, 5000);
}

TEST(RefineCycles, HundredThousandCyclesOnPrototypeCsOwnMesh) {
  // The 10^5 cycles on C's own 2426-node mesh: ~0.5 ms CPU per cycle (each rebuilds the
  // model), ~50 s on an idle core. Worth it: it is the case the issue names. Left out of the
  // sanitizer half of CI (.ci/run), where it would take ten times as long.
  const SceneConfig cfg = prototype_c();
  Scene scene = make_scene(cfg);
  run_cycles(cfg, scene.geometry().region_node("body"), 100000);
}
