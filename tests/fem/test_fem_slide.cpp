// Sliding presses on prototype D through the Scene (issue 12, issue 10): the contact force must be
// continuous as the contact point crosses faces and nodes — the per-step change of the force
// shrinks with the device's per-step travel (halving the travel halves the largest jump; a force
// centred on one node jumps by a fixed amount when the nearest node changes, whatever the
// travel) — on
//   - the condensed model's inverse-stiffness contact outside its operational region, which
//     also equals the full linear model's settled force at every point of the slide (1e-8);
//   - the multi-rate co-rotational model (quasi-static: a jump of the patch is rendered at once,
//     where the dynamic full model smooths it; that difference was the 30 % transient of the
//     first sliding bench, measured on a node-centred patch).
// The full linear model is stepped quasi-statically (h = 5 s: backward Euler is a damped
// fixed-point iteration to the static equilibrium).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <vector>

#include "engine/haptics/press.hpp"
#include "engine/models/model.hpp"
#include "prototypes/factory.hpp"
#include "tests/fem/quasi_static.hpp"
#include "tests/prototypes/prototype_text.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {

using palplab::engine::testing::proto;

using palplab::engine::testing::quasi_static;

// The device `depth` m inside the rest surface at a region's press node, moved `travel` m along
// a tangent of the node's normal in `steps` equal steps (one Scene step each; `settle` steps at
// the listed step indices). Returns the force of every step and counts the contact-node changes.
struct Slide {
  std::vector<Eigen::Vector3d> force;
  int node_changes = 0;
  double max_jump() const {  // largest per-step change of the force (N)
    double j = 0;
    for (size_t k = 1; k < force.size(); ++k) j = std::max(j, (force[k] - force[k - 1]).norm());
    return j;
  }
};

Slide slide(Scene& s, const std::string& region, double depth, double travel, int steps,
            const std::vector<int>& settle_at = {}, int settle = 0) {
  const SceneGeometry& g = s.geometry();
  const int node = press_node(g, region);
  const Eigen::Vector3d p = g.V.row(node).transpose(), n = g.N.row(node).transpose();
  const Eigen::Vector3d t = n.unitOrthogonal();
  Slide r;
  int last = -1;
  // Approach from outside so that the proxy engages at the node.
  for (int k = 0; k <= 4; ++k) s.step(p + (0.002 - k * (0.002 + depth) / 4) * n);
  for (int k = 0; k <= steps; ++k) {
    const Eigen::Vector3d x = p - depth * n + (travel * k / steps) * t;
    Rendered out = s.step(x);
    if (std::find(settle_at.begin(), settle_at.end(), k) != settle_at.end())
      for (int q = 0; q < settle; ++q) out = s.step(x);
    r.force.push_back(out.force);
    const int c = s.last_sample().contact_node;
    EXPECT_GE(c, 0) << "lost the contact at step " << k;
    if (last >= 0 && c != last) ++r.node_changes;
    last = c;
  }
  return r;
}

}  // namespace

// Condensed D, touched outside its operational region (ovary_left + 15 mm) on the right ovary:
// inverse-stiffness contact with the full linear model. The probe face is the contact face's
// three vertex pads blended by the barycentric weights (as in the main path), so the force is
// continuous across node changes and equals the full model's settled force everywhere.
TEST(FemSlide, CondensedOutsideContactIsContinuousAndEqualsTheFullModel) {
  SceneConfig cond = quasi_static("D");
  cond.fem.formulation = FemFormulation::condensed;
  cond.fem.operational_region = "ovary_left";
  cond.fem.operational_radius = 0.015;
  const double depth = 0.003, travel = 0.005;
  Scene sc = make_scene(cond);
  const Slide coarse = slide(sc, "ovary_right", depth, travel, 60);
  sc.reset();
  const Slide fine = slide(sc, "ovary_right", depth, travel, 120);
  const long outside =
      nlohmann::json::parse(sc.stats().model_info).at("fem").at("outside_contacts").get<long>();
  std::printf(
      "outside slide %.0f mm: %d node changes; largest per-step force change %.4g N "
      "(0.1 mm steps), %.4g N (0.05 mm steps)\n",
      1e3 * travel, fine.node_changes, coarse.max_jump(), fine.max_jump());
  EXPECT_GE(outside, 120);  // every step of the fine slide rendered outside
  ASSERT_GE(fine.node_changes, 1);
  EXPECT_GT(fine.force.back().norm(), 0.1);
  EXPECT_LT(fine.max_jump(), 0.6 * coarse.max_jump());  // O(travel per step): no fixed jump

  // The full linear D settles on the same force at points along the slide.
  Scene sf = make_scene(quasi_static("D"));
  const std::vector<int> at = {0, 23, 41, 60};
  const Slide full = slide(sf, "ovary_right", depth, travel, 60, at, 60);
  for (int k : at) {
    EXPECT_GT(full.force[k].norm(), 0.1);
    EXPECT_LT((coarse.force[k] - full.force[k]).norm(), 1e-8 * full.force[k].norm())
        << "step " << k << ": " << coarse.force[k].norm() << " vs " << full.force[k].norm();
  }
}

// The multi-rate co-rotational D at the haptic step (1 ms; a re-linearisation every 1/60 s, the
// worker waited for) pressed 4 mm into the left ovary, held until the updates converge, then
// slid 6 mm: the force rendered between updates (the patch's compliance about the last
// linearisation, the patch following the contact point) is continuous across node changes.
// A patch centred on the nearest node jumps there — rendered at once by this quasi-static model,
// smoothed by the dynamic full model: the 30 % transient difference of the first sliding bench.
TEST(FemSlide, MultirateSlideIsContinuousAcrossNodes) {
  const double depth = 0.004, travel = 0.006;
  SceneConfig mc = prototypes::load_prototype(proto("D_multirate"));
  mc.fem.multirate_deterministic = true;
  Scene sm = make_scene(mc);
  const std::vector<int> at = {0};  // hold at the start of the slide
  const Slide coarse = slide(sm, "ovary_left", depth, travel, 30, at, 50);
  sm.reset();
  const Slide fine = slide(sm, "ovary_left", depth, travel, 60, at, 50);
  std::printf(
      "multi-rate slide %.0f mm: %d node changes; largest per-step force change %.4g N "
      "(0.2 mm steps), %.4g N (0.1 mm steps); force %.3f -> %.3f N\n",
      1e3 * travel, fine.node_changes, coarse.max_jump(), fine.max_jump(),
      fine.force.front().norm(), fine.force.back().norm());
  ASSERT_GE(fine.node_changes, 1);
  EXPECT_GT(fine.force.front().norm(), 1.0);
  EXPECT_GT(fine.force.back().norm(), 0.1);
  EXPECT_LT(fine.max_jump(), 0.6 * coarse.max_jump());
  const nlohmann::json info = nlohmann::json::parse(sm.stats().model_info).at("fem");
  EXPECT_GE(info.at("relinearisations").get<long>(), 5);
  // The compliance columns are solved per vertex pad (3 back-substitutions each), not per step
  // of the slide (whose blend changes every step): the haptic step solved only the pads it met
  // between two updates (the worker solves the current ones at each update).
  // (Solving per blend did it at every one of the 91 sliding steps of both runs.)
  const size_t steps = coarse.force.size() + fine.force.size() + 2 * (5 + 50);
  std::printf("pads solved in the haptic step: %ld over %zu steps (both runs)\n",
              info.at("pad_solves").get<long>(), steps);
  EXPECT_LE(info.at("pad_solves").get<long>(), 30);
}
