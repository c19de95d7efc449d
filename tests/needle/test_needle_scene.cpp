// Prototype N through the Scene (issue 16 items 3-4): a scripted straight insertion on the
// procedural shoulder (tissue order of the events, tip-to-target distance against the analytic
// membrane sphere), the finger's force against its closed form over two bone depths, tool
// switching, and the needle measures computed from an event log.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "common/input_error.hpp"
#include "engine/haptics/scene_config.hpp"
#include "engine/mesh/materials.hpp"
#include "protocols/measures.hpp"
#include "prototypes/factory.hpp"

namespace {

using Eigen::Vector3d;
using palplab::engine::EventKind;
using palplab::engine::Rendered;
using palplab::engine::Scene;
using palplab::engine::SceneOverrides;

const std::string kNeedleProto = std::string(PALPLAB_SOURCE_DIR) + "/prototypes/N.json";

// The shoulder's joint (engine/mesh/generate.hpp): head centre and the membrane's outer radius.
const Vector3d kHead(0.022, 0.0, 0.0);
constexpr double kMembraneOuter = 0.0275;

Scene transparent_n() {
  SceneOverrides ov;
  ov.transparency = true;
  return palplab::prototypes::build_scene(kNeedleProto, ov);
}

struct Logged {
  double t;
  EventKind kind;
  std::string region;
  double value;
};

// Pushes the needle along +y at x = x0, z = 0 from y0 at `speed` until y1; logs events and the
// rendered tip-to-target distance per step.
std::vector<Logged> insert(Scene& s, double x0, double y0, double y1, double speed,
                           std::vector<std::pair<double, double>>* distance = nullptr) {
  s.set_tool("needle", Vector3d::UnitY());
  std::vector<Logged> ev;
  const double dy = speed * s.dt();
  for (double y = y0; y <= y1; y += dy) {
    const Rendered r = s.step(Vector3d(x0, y, 0.0));
    for (const auto& e : r.events)
      ev.push_back({e.t, e.kind,
                    e.region >= 0 ? s.geometry().region_names[e.region] : std::string(), e.value});
    if (distance) distance->push_back({y, r.visible_tip_to_target});
  }
  return ev;
}

std::vector<std::string> entered(const std::vector<Logged>& ev) {
  std::vector<std::string> out;
  for (const auto& e : ev)
    if (e.kind == EventKind::tissue_entered) out.push_back(e.region);
  return out;
}

TEST(NeedleScene, ScriptedPosteriorInsertionReachesTheCapsule) {
  Scene s = transparent_n();
  EXPECT_STREQ(s.model_kind(), "needle");
  EXPECT_EQ(s.tool(), "finger");  // N starts with the finger
  // x0 = -2 mm: the line y = -inf..inf meets the membrane shell (outer sphere at |p - c| =
  // 27.5 mm, inside its 40 deg cap) and then the humeral head (24 mm).
  const double x0 = -0.002;
  std::vector<std::pair<double, double>> dist;
  const auto ev = insert(s, x0, -0.09, -0.010, 0.005, &dist);
  const std::vector<std::string> order = entered(ev);
  ASSERT_GE(order.size(), 4u);
  EXPECT_EQ(order[0], "skin");
  EXPECT_EQ(order[1], "soft tissue");
  EXPECT_EQ(order[2], "muscle");
  EXPECT_EQ(order[3], "membrane");
  int starts = 0, targets = 0, tool_events = 0;
  for (const auto& e : ev) {
    starts += e.kind == EventKind::insertion_start;
    targets += e.kind == EventKind::target_reached;
    tool_events += e.kind == EventKind::tool_changed;
  }
  EXPECT_EQ(starts, 1);
  EXPECT_EQ(targets, 1);
  EXPECT_EQ(tool_events, 1);
  // The tissue events carry the attribute as value: skin 100, fat 101, muscle 300, membrane 107.
  std::vector<double> attrs;
  for (const auto& e : ev)
    if (e.kind == EventKind::tissue_entered) attrs.push_back(e.value);
  EXPECT_EQ(attrs[0], 100);
  EXPECT_EQ(attrs[1], 101);
  EXPECT_EQ(attrs[2], 300);
  EXPECT_EQ(attrs[3], 107);

  // Tip-to-target distance in the muscle, before the capsule deflects: radial distance to the
  // outer membrane sphere, |p - c| - 27.5 mm, where the direction from c lies inside the cap
  // (< 40 deg from -x). The mesh is a faceted sphere: within 0.3 mm.
  int checked = 0;
  for (const auto& [y, d] : dist) {
    const Vector3d p(x0, y, 0.0);
    const Vector3d v = p - kHead;
    const double angle = std::acos(-v.x() / v.norm()) * 180.0 / M_PI;
    if (y < -0.024 || y > -0.016 || angle > 38.0) continue;
    EXPECT_NEAR(d, v.norm() - kMembraneOuter, 3e-4) << "y = " << y;
    ++checked;
  }
  EXPECT_GT(checked, 100);
  // Inside the membrane the distance is 0.
  EXPECT_EQ(dist.back().second >= 0.0, true);
  bool zero_seen = false;
  for (const auto& [y, d] : dist) zero_seen = zero_seen || d == 0.0;
  EXPECT_TRUE(zero_seen);
}

TEST(NeedleScene, DistanceIsLoggedAsEventsAndHiddenWithoutTransparency) {
  Scene s = palplab::prototypes::build_scene(kNeedleProto, {});
  std::vector<std::pair<double, double>> dist;
  // Ends at y = -19 mm, where the direction from the head centre is 38 deg from -x (in the cap).
  const auto ev = insert(s, -0.002, -0.09, -0.019, 0.005, &dist);
  for (const auto& [y, d] : dist) EXPECT_EQ(d, -1.0);  // nothing shown
  // tip_to_target events: one per log_resolution (0.1 mm) of change, values decreasing here.
  std::vector<double> logged;
  for (const auto& e : ev)
    if (e.kind == EventKind::tip_to_target) logged.push_back(e.value);
  ASSERT_GT(logged.size(), 100u);
  for (size_t i = 1; i < logged.size(); ++i) {
    EXPECT_LT(logged[i], logged[i - 1]);
    EXPECT_GE(logged[i - 1] - logged[i], 1e-4 - 1e-12);
  }
  // The last logged distance is within the resolution of the analytic one at the final tip.
  const Vector3d v = Vector3d(-0.002, dist.back().first, 0.0) - kHead;
  EXPECT_NEAR(logged.back(), v.norm() - kMembraneOuter, 1e-4 + 3e-4);
}

TEST(NeedleScene, WithdrawingLeavesTheTissuesInReverseAndANewInsertionCounts) {
  Scene s = palplab::prototypes::build_scene(kNeedleProto, {});
  auto ev = insert(s, -0.002, -0.09, -0.050, 0.005);
  // Pull back out along -y.
  std::vector<std::string> left;
  for (double y = -0.050; y >= -0.09; y -= 2e-5) {
    const Rendered r = s.step(Vector3d(-0.002, y, 0.0));
    for (const auto& e : r.events)
      if (e.kind == EventKind::tissue_left) left.push_back(s.geometry().region_names[e.region]);
  }
  ASSERT_GE(left.size(), 3u);
  EXPECT_EQ(left[left.size() - 1], "skin");
  EXPECT_EQ(left[left.size() - 2], "soft tissue");
  EXPECT_EQ(left[left.size() - 3], "muscle");
  ev = insert(s, 0.0, -0.09, -0.06, 0.005);
  int starts = 0;
  for (const auto& e : ev) starts += e.kind == EventKind::insertion_start;
  EXPECT_EQ(starts, 1);
  EXPECT_EQ(s.stats().model_info.find("\"insertions\":2") != std::string::npos, true)
      << s.stats().model_info;
}

TEST(NeedleScene, LateralInsertionHitsTheHumerus) {
  Scene s = palplab::prototypes::build_scene(kNeedleProto, {});
  s.set_tool("needle", -Vector3d::UnitX());
  int bone = 0;
  std::string bone_region;
  Vector3d f = Vector3d::Zero();
  for (double x = 0.09; x >= 0.040; x -= 5e-6) {
    const Rendered r = s.step(Vector3d(x, 0.0, 0.0));
    for (const auto& e : r.events)
      if (e.kind == EventKind::bone_contact) {
        ++bone;
        bone_region = s.geometry().region_names[e.region];
      }
    f = r.force;
  }
  EXPECT_EQ(bone, 1);
  EXPECT_EQ(bone_region, "bone");
  // One region per tissue name: the humerus and the scapula are one "bone" (it was listed twice,
  // the second never used).
  EXPECT_EQ(s.geometry().region_names,
            (std::vector<std::string>{"skin", "soft tissue", "membrane", "bone", "muscle"}));
  // Pressed 6 mm into the bone wall: the force is the device's limit, along +x (out).
  EXPECT_NEAR(f.x(), s.config().contact.force_limit, 1e-9);
}

// The finger's force law (engine/models/needle_model.cpp) evaluated by hand for a skin point
// above the humeral head's lateral pole (bone at x = 22 + 24 = 46 mm).
double finger_closed_form(double h, double d, const palplab::engine::NeedleSceneConfig& c) {
  const auto& t = palplab::mesh::default_materials();
  // The modulus is that of the first 3 finger radii (24 mm) of tissue: skin, fat, muscle.
  const double window = 3 * c.finger_radius;
  const double skin = 0.002, fat = 0.010, muscle = window - skin - fat;
  const double compliance = skin / t.find(100)->youngs_modulus + fat / t.find(101)->youngs_modulus +
                            muscle / t.find(300)->youngs_modulus;
  const double E = window / compliance, a = c.finger_radius, nu = 0.45;
  const double k = 2 * E * a / (1 - nu * nu) + E * M_PI * a * a / h;
  return k * h / c.stiffening * std::expm1(c.stiffening * d / h) +
         c.bone_stiffness * std::max(0.0, d - 0.7 * h);
}

TEST(NeedleScene, FingerForceReflectsTheBoneDepth) {
  Scene s = palplab::prototypes::build_scene(kNeedleProto, {});
  const auto& g = s.geometry();
  // The lateral pole of the skin and a posterior point over the joint line.
  const int lateral = g.nearest_node(Vector3d(0.08, 0.0, 0.0));
  const int posterior = g.nearest_node(Vector3d(-0.003, -0.08, 0.0));
  auto press = [&](int node, double depth) {
    s.reset();
    const Vector3d p = g.V.row(node).transpose(), n = g.N.row(node).transpose();
    Rendered r;
    for (int i = 0; i <= 200; ++i) r = s.step(p + n * 0.005 - n * (0.005 + depth) * i / 200.0);
    return r.force.dot(n);
  };
  const double d = 0.005;
  const double f_lat = press(lateral, d);
  const double f_post = press(posterior, d);
  // Lateral: soft tissue from the skin node to the head (|x| = 46 mm along the normal ~ +x).
  const Vector3d pl = g.V.row(lateral).transpose();
  const double h_lat = pl.x() - (kHead.x() + 0.024);
  EXPECT_NEAR(f_lat, finger_closed_form(h_lat, d, s.config().needle), 0.03 * f_lat);
  EXPECT_GT(f_lat, 1.1 * f_post);  // shallow bone feels stiffer than the joint line
  EXPECT_GT(f_post, 0.5);
}

TEST(NeedleScene, ToolsAreExplicit) {
  Scene s = palplab::prototypes::build_scene(kNeedleProto, {});
  EXPECT_THROW(s.set_tool("scalpel", Vector3d::UnitY()), palplab::InputError);
  EXPECT_THROW(s.set_tool("needle", Vector3d::Zero()), palplab::InputError);
  s.set_tool("needle", Vector3d::UnitY());
  EXPECT_EQ(s.tool(), "needle");
  s.reset();
  EXPECT_EQ(s.tool(), "finger");  // back to the prototype's start tool
  // A palpation prototype has the one tool "probe".
  Scene a =
      palplab::prototypes::build_scene(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/A.json", {});
  EXPECT_EQ(a.tool(), "probe");
  EXPECT_THROW(a.set_tool("needle", Vector3d::UnitY()), palplab::InputError);
}

TEST(NeedleMeasures, FromAnEventLog) {
  using palplab::results::EventRecord;
  const std::vector<EventRecord> ev = {{0.5, "tool_changed", 1, ""},
                                       {1.0, "insertion_start", 1, ""},
                                       {1.1, "tissue_entered", 100, "skin"},
                                       {1.2, "tissue_entered", 101, "soft tissue"},
                                       {1.3, "bone_contact", 201, "bone"},
                                       {1.4, "tip_to_target", 0.02, ""},
                                       {2.0, "insertion_start", 2, ""},
                                       {2.1, "tissue_entered", 100, "skin"},
                                       {2.2, "tissue_entered", 101, "soft tissue"},
                                       {2.3, "tissue_entered", 300, "muscle"},
                                       {2.4, "tissue_left", 300, "muscle"},
                                       {2.4, "tissue_entered", 107, "membrane"},
                                       {2.4, "target_reached", 107, "membrane"},
                                       {2.5, "tip_to_target", 0.0, ""},
                                       {2.6, "tissue_left", 107, "membrane"},
                                       {2.6, "tissue_entered", 300, "muscle"},
                                       {2.7, "tip_to_target", 0.0012, ""},
                                       {9.0, "contact_end", 1.0, ""}};
  const auto m = palplab::protocols::compute_needle_measures(ev);
  auto get = [&](const std::string& n) {
    for (const auto& r : m)
      if (r.name == n) return r.value;
    ADD_FAILURE() << n;
    return std::optional<double>();
  };
  EXPECT_EQ(get("insertion_attempts"), 2.0);
  EXPECT_EQ(get("bone_contacts"), 1.0);
  EXPECT_EQ(get("layers_passed"), 4.0);  // skin, soft tissue, muscle, membrane (muscle once)
  EXPECT_NEAR(*get("tip_to_target_mm"), 1.2, 1e-12);
  EXPECT_NEAR(*get("procedure_time"), 2.7, 1e-12);  // contact_end is no needle event
  const auto none = palplab::protocols::compute_needle_measures({});
  EXPECT_FALSE(none[2].value.has_value());
  EXPECT_FALSE(none[4].value.has_value());
  EXPECT_EQ(none[0].value, 0.0);
}

}  // namespace
