// The needle model on an analytic layered slab (issue 16).
#include <gtest/gtest.h>

#include <map>

#include "common/input_error.hpp"
#include "engine/mesh/materials.hpp"
#include "engine/models/needle.hpp"
#include "tests/needle/slab.hpp"

namespace palplab::engine {
namespace {

using needle_testing::layered_slab;
using needle_testing::SlabLayer;
using Kind = NeedleEvent::Kind;

// skin 2 mm, fat 8 mm, muscle 15 mm, membrane 2 mm, muscle 3 mm, bone 10 mm.
// Interfaces at depths 0, 2, 10, 25, 27, 30 mm.
const std::vector<SlabLayer> kLayers = {{0.002, 100}, {0.008, 101}, {0.015, 300},
                                        {0.002, 107}, {0.003, 300}, {0.010, 200}};

const mesh::NeedleParams& params(int tissue) {
  return mesh::default_materials().find(tissue)->needle;
}

struct Insertion {
  std::vector<NeedleStep> steps;
  std::vector<NeedleEvent> events;
};

// Straight insertion along -z from 5 mm above the slab down to depth `to` (m) in steps of ds.
Insertion insert(NeedleModel& model, double to, double ds,
                 const Vec3& xy = Vec3(0.0013, 0.0021, 0)) {
  Insertion r;
  const Vec3 axis(0, 0, -1);
  for (double z = 0.005; z >= -to - 1e-12; z -= ds) {
    r.steps.push_back(model.step(Vec3(xy.x(), xy.y(), z), axis));
    for (auto& e : r.steps.back().events) r.events.push_back(e);
  }
  return r;
}

TEST(NeedleSlab, LayersAlongTheAxisAreTheSlabLayers) {
  const NeedleModel model(layered_slab(kLayers), mesh::default_materials());
  const auto layers = model.layers_along(Vec3(0.0013, 0.0021, 0.005), Vec3(0, 0, -1));
  // outside, then the six layers merged by tissue change, then outside below the slab.
  const std::vector<int> tissues = {-1, 100, 101, 300, 107, 300, 200, -1};
  ASSERT_EQ(layers.size(), tissues.size());
  const double enters[] = {0, 0.005, 0.007, 0.015, 0.030, 0.032, 0.035, 0.045};
  for (size_t i = 0; i < layers.size(); ++i) {
    EXPECT_EQ(layers[i].tissue, tissues[i]) << i;
    EXPECT_NEAR(layers[i].enter, enters[i], 1e-12) << i;
  }
  EXPECT_EQ(model.tissue_at(Vec3(0, 0, -0.026)), 107);
  EXPECT_EQ(model.tissue_at(Vec3(0, 0, 0.001)), -1);
  EXPECT_NEAR(model.distance_to_target(Vec3(0.003, -0.002, -0.004)), 0.021, 1e-12);
  EXPECT_NEAR(model.distance_to_target(Vec3(0.003, -0.002, -0.0285)), 0.0015, 1e-12);
  EXPECT_EQ(model.distance_to_target(Vec3(0.003, -0.002, -0.026)), 0);
}

TEST(NeedleSlab, StraightInsertionEmitsTheLayerSequenceAndTheTargetDistance) {
  NeedleModel model(layered_slab(kLayers), mesh::default_materials());
  const double ds = 1e-5;
  const Insertion r = insert(model, 0.040, ds);
  std::vector<std::pair<Kind, int>> got;
  for (auto& e : r.events) got.emplace_back(e.kind, e.tissue);
  const std::vector<std::pair<Kind, int>> want = {
      {Kind::tissue_entered, 100}, {Kind::tissue_left, 100},    {Kind::tissue_entered, 101},
      {Kind::tissue_left, 101},    {Kind::tissue_entered, 300}, {Kind::tissue_left, 300},
      {Kind::tissue_entered, 107}, {Kind::target_reached, 107}, {Kind::tissue_left, 107},
      {Kind::tissue_entered, 300}, {Kind::bone_contact, 200}};
  EXPECT_EQ(got, want);
  EXPECT_EQ(model.entered(), (std::vector<int>{100, 101, 300, 107, 300}));
  EXPECT_EQ(model.bone_contacts(), 1);
  EXPECT_EQ(model.insertions(), 1);
  // Events sit on the interfaces (depth below the entry point at z = 0).
  for (auto& e : r.events) {
    if (e.kind == Kind::tissue_entered && e.tissue == 107) {
      EXPECT_NEAR(e.depth, 0.025, 1e-12);
    }
    if (e.kind == Kind::bone_contact) {
      EXPECT_NEAR(e.depth, 0.030, 1e-12);
    }
  }
  // Tip-to-target: 25 mm - depth above the membrane, 0 inside, depth - 27 mm below it, for
  // every step where the tip moves freely (not pressing an interface).
  int checked = 0;
  for (const NeedleStep& s : r.steps) {
    if (!s.inserted || s.tip_force > 0) continue;
    const double d = s.tip_depth;
    const double want_d = d < 0.025 ? 0.025 - d : (d <= 0.027 ? 0.0 : d - 0.027);
    ASSERT_NEAR(s.tip_to_target, want_d, 1e-12) << "depth " << d;
    ++checked;
  }
  EXPECT_GT(checked, 1500);
  // The bone stops the tip: it never goes deeper than the bone surface.
  EXPECT_NEAR(r.steps.back().tip_depth, 0.030, 1e-12);
  EXPECT_NEAR(r.steps.back().tip_force, params(200).puncture_stiffness * 0.010, 1e-9);
  EXPECT_EQ(r.steps.back().tissue, 300);
}

TEST(NeedleSlab, PunctureHappensAtTheThresholdForce) {
  NeedleModel model(layered_slab(kLayers), mesh::default_materials());
  const double ds = 1e-5;
  const Insertion r = insert(model, 0.016, ds);
  // For each tissue, the last pre-puncture spring force and the one that punctured.
  struct Seen {
    double last_below = 0;
    bool punctured = false;
  };
  std::map<int, Seen> seen;
  int pressing = -1;  // tissue whose interface is pressed
  for (size_t i = 0; i < r.steps.size(); ++i) {
    const NeedleStep& s = r.steps[i];
    bool cascade = false;  // an earlier puncture in this step
    for (auto& e : s.events)
      if (e.kind == Kind::tissue_entered) {
        seen[e.tissue].punctured = true;
        // The spring force the commanded depth produces on this interface is >= the threshold.
        const double f = params(e.tissue).puncture_stiffness * (s.depth - e.depth);
        EXPECT_GE(f, params(e.tissue).puncture_force - 1e-12) << e.tissue;
        if (!cascade) {
          // Pressed first, and one step earlier the force was below the threshold by less than
          // one step's worth: puncture at the first step over it.
          ASSERT_EQ(pressing, e.tissue) << "entered without pressing first";
          EXPECT_LT(seen[e.tissue].last_below, params(e.tissue).puncture_force);
          EXPECT_GT(seen[e.tissue].last_below, params(e.tissue).puncture_force -
                                                   params(e.tissue).puncture_stiffness * ds * 1.01);
        }
        // A popped interface lets the tip jump to the commanded depth; the next interface may
        // then be punctured in the same step (skin deflects 5 mm > its 2 mm thickness).
        cascade = true;
        pressing = -1;
      }
    if (s.tip_force > 0) {
      // Before puncture the interface is a spring: F = k (s - b) exactly.
      const int next = s.tissue < 0 ? 100 : (s.tissue == 100 ? 101 : 300);
      EXPECT_NEAR(s.tip_force, params(next).puncture_stiffness * (s.depth - s.tip_depth), 1e-12);
      EXPECT_LT(s.tip_force, params(next).puncture_force);
      seen[next].last_below = s.tip_force;
      pressing = next;
    }
  }
  EXPECT_TRUE(seen[100].punctured);
  EXPECT_TRUE(seen[101].punctured);
  EXPECT_TRUE(seen[300].punctured);
  // Skin puncture only after the skin deflected F_p / k (5 mm with the default table).
  const double deflection = params(100).puncture_force / params(100).puncture_stiffness;
  for (const NeedleStep& s : r.steps)
    if (s.tissue == 100) {
      EXPECT_GE(s.depth, deflection - 1e-12);
      break;
    }
}

TEST(NeedleSlab, ShaftFrictionAndCuttingMatchTheLayerLengths) {
  NeedleModel model(layered_slab(kLayers), mesh::default_materials());
  const Insertion r = insert(model, 0.020, 1e-5);
  // In the muscle after the puncture transient: friction = sum_i f_i L_i, cutting of muscle.
  int checked = 0;
  for (const NeedleStep& s : r.steps) {
    if (s.tissue != 300 || s.tip_force > 0 || s.tip_depth < 0.0125) continue;
    const double want = params(100).friction * 0.002 + params(101).friction * 0.008 +
                        params(300).friction * (s.tip_depth - 0.010);
    EXPECT_NEAR(s.friction_force, want, 1e-9);
    EXPECT_DOUBLE_EQ(s.cutting_force, params(300).cutting_force);
    EXPECT_NEAR(s.axial_force, want + params(300).cutting_force, 1e-9);
    EXPECT_NEAR(s.force.z(), s.axial_force, 1e-12);  // on the hand: -F a, a = -z
    ++checked;
  }
  EXPECT_GT(checked, 500);
  // Withdrawal: friction reverses, no cutting, and the layers are left in reverse order.
  std::vector<NeedleEvent> back;
  NeedleStep s;
  for (double z = -0.020; z <= 0.005; z += 1e-4) {
    s = model.step(Vec3(0.0013, 0.0021, z), Vec3(0, 0, -1));
    if (z < -0.012 && z > -0.0195) {
      EXPECT_LT(s.friction_force, 0);
      EXPECT_EQ(s.cutting_force, 0);
    }
    for (auto& e : s.events) back.push_back(e);
  }
  std::vector<std::pair<Kind, int>> got;
  for (auto& e : back) got.emplace_back(e.kind, e.tissue);
  const std::vector<std::pair<Kind, int>> want = {{Kind::tissue_left, 300},
                                                  {Kind::tissue_entered, 101},
                                                  {Kind::tissue_left, 101},
                                                  {Kind::tissue_entered, 100},
                                                  {Kind::tissue_left, 100}};
  EXPECT_EQ(got, want);
  EXPECT_FALSE(s.inserted);
  // Re-insertion is a new attempt, with a new skin puncture.
  const Insertion again = insert(model, 0.008, 1e-5);
  EXPECT_EQ(model.insertions(), 2);
  ASSERT_FALSE(again.events.empty());
  EXPECT_EQ(again.events.front().kind, Kind::tissue_entered);
  EXPECT_EQ(again.events.front().tissue, 100);
}

TEST(NeedleSlab, ReadvancingInTheTrackHasNoPuncturePeak) {
  NeedleModel model(layered_slab(kLayers), mesh::default_materials());
  insert(model, 0.015, 1e-5);
  // Back up to 5 mm depth (inside the fat), then forward again to 15 mm.
  for (double z = -0.015; z <= -0.005; z += 1e-5)
    model.step(Vec3(0.0013, 0.0021, z), Vec3(0, 0, -1));
  for (double z = -0.005; z >= -0.0149; z -= 1e-5) {
    const NeedleStep s = model.step(Vec3(0.0013, 0.0021, z), Vec3(0, 0, -1));
    EXPECT_EQ(s.tip_force, 0) << z;
    EXPECT_EQ(s.cutting_force, 0) << z;  // the track is already cut
  }
}

TEST(NeedleSlab, MissingNeedleParametersAreAnInputError) {
  mesh::MaterialTable t = mesh::default_materials();
  for (auto& m : t.materials)
    if (m.name == "muscle") m.needle.defined = false;
  EXPECT_THROW(NeedleModel(layered_slab(kLayers), t), palplab::InputError);
  mesh::TetMesh no_target = layered_slab({{0.002, 100}, {0.01, 101}});
  EXPECT_THROW(NeedleModel(no_target, mesh::default_materials()), palplab::InputError);
}

TEST(NeedleMaterials, TableRoundTripKeepsNeedleParameters) {
  const mesh::MaterialTable t =
      mesh::parse_materials(mesh::materials_to_json(mesh::default_materials()), "rt");
  const auto* skin = t.find(100);
  ASSERT_TRUE(skin && skin->needle.defined);
  EXPECT_EQ(skin->needle.puncture_force, params(100).puncture_force);
  EXPECT_EQ(skin->needle.friction, params(100).friction);
  EXPECT_FALSE(skin->needle.source.empty());
  EXPECT_THROW(
      mesh::parse_materials(
          R"({"materials":[{"first":1,"last":1,"name":"x","youngs_modulus":1,)"
          R"("poisson_ratio":0.3,"density":1,"colour":[0,0,0],)"
          R"("needle":{"puncture_force":-1,"puncture_stiffness":1,"cutting_force":0,"friction":0}}]})",
          "bad.json"),
      palplab::InputError);
}

}  // namespace
}  // namespace palplab::engine
