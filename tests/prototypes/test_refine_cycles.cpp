// Issue 10's hard case "10^5 refine/simplify cycles": the adaptive refinement of prototype C,
// built exactly as the model builds it (mass_spring_adaptive), refined around the nodes of the
// touched patch and simplified again 10^5 times, on a deformed (pressed) state. Each cycle
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

}  // namespace

TEST(RefineCycles, HundredThousandCyclesOnTheTouchedPatchOfPrototypeC) {
  const SceneConfig cfg =
      prototypes::load_prototype(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/C.json");
  ASSERT_TRUE(cfg.refinement.enabled);
  const auto cm = scene_mesh(cfg.mesh);
  AdaptiveMassSpring m = mass_spring_adaptive(cfg, *cm);
  Scene scene = make_scene(cfg);
  const SceneGeometry& g = scene.geometry();
  const int press = g.region_node("body");
  const Eigen::Vector3d p = g.V.row(press).transpose(), n = g.N.row(press).transpose();
  // The touched patch: the surface nodes within the probe's radius of the press node — the
  // nodes a sliding contact refines around.
  std::vector<int> patch;
  for (long i = 0; i < g.V.rows(); ++i)
    if ((g.V.row(i).transpose() - p).norm() <= cfg.contact.patch_radius)
      patch.push_back(cm->surface_to_model[i]);
  ASSERT_GE(patch.size(), 10u);
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
  const int cycles = 100000;
  long refined = 0, max_nodes = 0;
  double e_lo = INFINITY, e_hi = 0;
  size_t heap_at_1000 = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (int c = 0; c < cycles; ++c) {
    const int node = patch[c % patch.size()];
    refined += refine_around(m, node, cfg.refinement.params);
    max_nodes = std::max(max_nodes, s.nodes());
    // While refined: the mass is the coarse mass (the refinement redistributes it, 1e-12),
    // nothing is NaN, and the energy of the same state (new nodes at their parents' midpoints)
    // stays within a bound of the coarse energy (checked every 97th cycle: O(#springs)).
    ASSERT_NEAR(s.mass.sum(), M0, 1e-12 * M0) << "cycle " << c;
    if (c % 97 == 0) {
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
    if (c % 97 == 0) {
      ASSERT_TRUE((s.mass.array() == coarse.mass.array()).all()) << "cycle " << c;
      ASSERT_TRUE((s.X.array() == coarse.X.array()).all()) << "cycle " << c;
      ASSERT_EQ(elastic_energy(s), E0) << "cycle " << c;
    }
    if (c == 999) heap_at_1000 = mallinfo2().uordblks;
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const size_t heap_end = mallinfo2().uordblks;
  std::printf(
      "%d cycles on %zu patch nodes in %.2f s (%.1f us/cycle); refined %ld times, up to %ld "
      "nodes (coarse %ld); energy while refined %.4f .. %.4f of the coarse; heap %zu -> %zu\n",
      cycles, patch.size(), secs, 1e6 * secs / cycles, refined, max_nodes, nodes0, e_lo, e_hi,
      heap_at_1000, heap_end);
  EXPECT_EQ(refined, cycles);  // every cycle refined (the patch's faces are above A_t)
  EXPECT_GT(max_nodes, nodes0);
  // The same state refined has the energy of its coarse form to a few per cent (midpoints of a
  // smooth field; the membrane shares move to the leaves, refinement.hpp) — never growing.
  EXPECT_GT(e_lo, 0.9);
  EXPECT_LT(e_hi, 1.1);
  EXPECT_LE(heap_end, heap_at_1000 + 4096) << "heap grew";
}
