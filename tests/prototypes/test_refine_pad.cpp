// Refinement on/off along the whole press (issue 9): the device's secant stiffness at 1, 2.5 and
// 4 N with adaptive refinement on and off, on prototype C's tet tract and the Model-A tract
// surface as a membrane, at the ovary and at the body. The probe face is a disc of quadrature
// points on the surface (engine/models/contact_pad.hpp), the same disc on the coarse and the
// refined mesh, so the press loads both alike.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "common/input_error.hpp"
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
  return palplab::engine::testing::variant_file(std::move(text), "refpad_" + name, edits);
}

// C, C1 and C2 ship with the disc pad; the vertex pads are the variant.
constexpr const char* kDiscPad = "\"contact_pad\": \"disc\"";
constexpr const char* kVertexPads = "\"contact_pad\": \"vertices\"";

constexpr double kForces[3] = {1.0, 2.5, 4.0};  // N

struct Curve {
  double k[3] = {0, 0, 0};  // N/m: secant stiffness of the device at kForces
  long new_nodes = 0;
};

// One press script at the surface node nearest `point`, in to 4 N: the secant stiffness
// F / (depth - depth at first contact) on the way in, as each force is passed.
// `region`: press its press node instead (the node nearest its centroid, as exp2 does).
Curve press_curve(const std::string& path, const Eigen::Vector3d& point,
                  const std::string& region = "") {
  Scene s = prototypes::build_scene(path);
  const SceneGeometry& g = s.geometry();
  const int node = region.empty() ? g.nearest_node(point) : g.region_node(region);
  PressDevice d(press_at(g, node, kForces[2], 0.05, 0.05));
  Curve r;
  double d0 = -1;
  LockstepOptions o;
  o.duration = 1e6;
  o.frame_period = 0;
  run_lockstep(s, d, o, [&](const Rendered& x, const Sample&) {
    const double f = x.force.norm();
    if (f > 0 && d0 < 0) d0 = d.depth();
    if (d.phase() == PressPhase::approach && d0 >= 0)
      for (int i = 0; i < 3; ++i)
        if (f < kForces[i]) r.k[i] = f / std::max(d.depth() - d0, 1e-9);
  });
  EXPECT_TRUE(d.force_reached()) << path;
  r.new_nodes = s.stats().new_nodes_max;
  return r;
}

using palplab::engine::testing::kBody;
using palplab::engine::testing::kOvary;

// The press curve with refinement on and off.
struct OnOff {
  Curve on, off;
};
OnOff on_off(const std::string& text, const Eigen::Vector3d& point) {
  const std::string on = variant(text, "on", {});
  const std::string off =
      variant(text, "off", {{"\"enabled\": true, \"policy\"", "\"enabled\": false, \"policy\""}});
  OnOff r{press_curve(on, point), press_curve(off, point)};
  EXPECT_GT(r.on.new_nodes, 0);
  EXPECT_EQ(r.off.new_nodes, 0);
  return r;
}

void print(const std::string& name, const OnOff& r) {
  for (int i = 0; i < 3; ++i)
    std::printf("%-32s %.1f N: on %6.1f off %6.1f N/m (%+.1f %%)\n", name.c_str(), kForces[i],
                r.on.k[i], r.off.k[i], 100 * (r.on.k[i] - r.off.k[i]) / r.off.k[i]);
}

// On and off within the force Weber fraction (7 %, issue 9: a difference the hand cannot tell)
// of their mean, at every force of the curve, not only at 2.5 N.
void expect_agree(const std::string& name, const OnOff& r) {
  for (int i = 0; i < 3; ++i)
    EXPECT_LT(std::abs(r.on.k[i] - r.off.k[i]), 0.07 * 0.5 * (r.on.k[i] + r.off.k[i]))
        << name << " at " << kForces[i] << " N: on " << r.on.k[i] << ", off " << r.off.k[i];
}

// The tract models, with the disc pad (as shipped) or the vertex pads.
struct Models {
  std::string c, membrane;
};
Models models(bool disc) {
  std::string c = read(proto("C"));  // C ships with the disc pad
  if (!disc) c = read(variant(c, "vertices", {{kDiscPad, kVertexPads}}));
  const std::string m = variant(c, disc ? "tract_surface_disc" : "tract_surface",
                                {{"\"generator\": \"model_c\", \"vertices\": 1600",
                                  "\"generator\": \"tract\", \"vertices\": 1500"},
                                 {"\"rayleigh_beta\"", "\"thickness\": 0.01, \"rayleigh_beta\""}});
  return {c, read(m)};
}

}  // namespace

TEST(Physics, RefinementOnOffAgreesFrom1To4NAtTheOvary) {
  // Model-C and the Model-A tract surface as a membrane, at the ovary (coarse edges ~4 mm, finer
  // than the 1 cm probe face), with either pad: the whole curve agrees (measured within 2 %).
  for (bool disc : {false, true}) {
    const Models m = models(disc);
    const std::string pad = disc ? "disc pad" : "vertex pads";
    for (const auto& [name, text] : {std::pair{"C ovary, " + pad, m.c},
                                     std::pair{"Model-A membrane ovary, " + pad, m.membrane}}) {
      const OnOff r = on_off(text, kOvary);
      print(name, r);
      expect_agree(name, r);
    }
  }
}

TEST(Physics, DiscPadKeepsTheShapeOfTheCurveAtTheBody) {
  // C's body (coarse edges 12.9 mm, longer than the probe face's radius). With the vertex pads
  // the refined pad rests on the whole face and the coarse one on one node, so the two curves
  // cross: on/off -19 %, +12 %, +32 % at 1, 2.5, 4 N (the coarse single-node press softens
  // with the force). The disc pad loads the coarse and the refined mesh alike, and the ratio
  // on/off is the same along the curve (measured -9.6, -10.1, -11.3 %; asserted: within 3 % of
  // each other): the coarse body's own discretisation error, its faces being larger than the
  // probe face (test_refine_depth.cpp; before the dent ties of refinement.hpp -23.9, -24.7,
  // -25.0 %, growing with the level).
  const OnOff r = on_off(models(true).c, kBody);
  print("C body, disc pad", r);
  double lo = INFINITY, hi = -INFINITY;
  for (int i = 0; i < 3; ++i) {
    const double ratio = r.on.k[i] / r.off.k[i];
    lo = std::min(lo, ratio);
    hi = std::max(hi, ratio);
  }
  EXPECT_LT(hi - lo, 0.03) << lo << " .. " << hi;
  // And unrefined, the disc pad's body stiffness does not depend on the mesh: see
  // DiscPadStiffnessDoesNotDependOnTheMesh.
}

TEST(Physics, MembraneAtTheBodyTheUnrefinedCoarseMeshIsTheOutlier) {
  // The Model-A tract surface as a membrane at C's body, refinement on and off, on the shipped
  // 1500-vertex surface and on the same organ with 6000 vertices. Measured (N/m at 1 / 2.5 /
  // 4 N):
  //   vertex pads  1500 on 136.8 / 257.3 / 371.2   off 107.2 / 187.7 / 264.4
  //                6000 on 148.0 / 247.5 / 332.6   off 138.9 / 234.8 / 316.8
  //   disc pad     1500 on 146.8 / 262.2 / 368.1   off 243.8 / 287.4 / 367.6
  //                6000 on 159.9 / 254.8 / 337.0   off 167.6 / 261.7 / 344.9
  // (3000 vertices: on/off -3.9 / -3.2 / -3.0 % with the vertex pads, -8.6 / -5.0 / -4.2 %
  // with the disc.) The refined 1500 mesh is near the 6000 mesh; the unrefined 1500 mesh is
  // not: its body faces are larger than the 1 cm probe face, so one vertex pad holds the press
  // (too soft) or the disc bends whole flat faces (too stiff at 1 N). So the on/off difference
  // at the body is the coarse mesh's error, not refinement's; on the 6000 mesh on/off agree
  // within the Weber fraction with either pad.
  for (bool disc : {false, true}) {
    const std::string m = models(disc).membrane;
    const std::string pad = disc ? "disc pad" : "vertex pads";
    const std::string fine = read(
        variant(m, disc ? "mem6000d" : "mem6000v", {{"\"vertices\": 1500", "\"vertices\": 6000"}}));
    const OnOff coarse = on_off(m, kBody), fine_r = on_off(fine, kBody);
    print("membrane 1500, " + pad, coarse);
    print("membrane 6000, " + pad, fine_r);
    expect_agree("membrane 6000 at the body, " + pad, fine_r);
    for (int i = 0; i < 2; ++i)  // 1 and 2.5 N
      EXPECT_LT(std::abs(coarse.on.k[i] - fine_r.off.k[i]),
                std::abs(coarse.off.k[i] - fine_r.off.k[i]))
          << pad << " at " << kForces[i] << " N";
  }
}

TEST(Physics, DiscPadStiffnessDoesNotDependOnTheMesh) {
  // Model-C at three resolutions (1689, 2426, 4565 nodes), refinement off, disc pad: secant
  // stiffness at 2.5 N within the Weber fraction of the mean at the ovary and at the body
  // (measured -1.9/+1.1 % and -1.6/+0.9 %).
  const std::string c = models(true).c;
  for (const auto& [where, point] : {std::pair{"ovary", kOvary}, std::pair{"body", kBody}}) {
    std::vector<double> k;
    for (const char* v : {"1200", "1600", "2440"}) {
      const std::string path =
          variant(c, std::string("disc_res_") + v,
                  {{"\"vertices\": 1600", std::string("\"vertices\": ") + v},
                   {"\"enabled\": true, \"policy\"", "\"enabled\": false, \"policy\""}});
      k.push_back(press_curve(path, point).k[1]);
    }
    const double mean = (k[0] + k[1] + k[2]) / 3;
    for (double x : k) EXPECT_LT(std::abs(x - mean), 0.07 * mean) << where << ": " << x;
    std::printf("disc pad, C at 2.5 N, %s: %.1f %.1f %.1f N/m\n", where, k[0], k[1], k[2]);
  }
}

TEST(Physics, RefinementOnOffAgreesAtExpTwosPressNodes) {
  // exp2 presses ovary_left and ovary_right (the node nearest each centroid): on/off within the
  // Weber fraction along the curve, with either pad. The pads differ there (measured at 2.5 N:
  // 405.8 / 402.7 N/m with the vertex pads, 359.6 / 356.6 with the disc, -11 %; a vertex pad's
  // nodes carry their whole lumped area, which reaches about half an edge beyond the radius —
  // a likely cause, not measured).
  const std::string vertices =
      variant(read(proto("C")), "exp2_vertices", {{kDiscPad, kVertexPads}});
  for (const std::string& text : {read(vertices), read(proto("C"))})
    for (const char* region : {"ovary_left", "ovary_right"}) {
      const std::string on = variant(text, "exp2_on", {});
      const std::string off = variant(
          text, "exp2_off", {{"\"enabled\": true, \"policy\"", "\"enabled\": false, \"policy\""}});
      const OnOff r{press_curve(on, kOvary, region), press_curve(off, kOvary, region)};
      EXPECT_GT(r.on.new_nodes, 0);
      const bool is_disc = text.find(kDiscPad) != std::string::npos;
      const std::string name =
          std::string("C ") + region + (is_disc ? ", disc pad" : ", vertex pads");
      print(name, r);
      expect_agree(name, r);
    }
}

TEST(Physics, DiscPadMovesContinuouslyWhenSliding) {
  // C with the disc pad, refinement off, held at 2.5 N at the body while the contact point
  // slides 2 cm at 2 cm/s across coarse nodes (12.9 mm edges): the disc is made anew each step
  // from the contact point, so the force changes smoothly. Bound: 3.5 % of the smallest force
  // per 1 ms step (half the Weber fraction; D's bound in ContactHard.SlidingAcrossNodes...).
  const std::string path =
      variant(read(proto("C")), "slide_disc",
              {{"\"enabled\": true, \"policy\"", "\"enabled\": false, \"policy\""}});
  Scene s = prototypes::build_scene(path);
  const SceneGeometry& g = s.geometry();
  PressSpec p = press_at(g, g.nearest_node(kBody), 2.5, 1.0, 0.05);
  const Eigen::Vector3d a =
      std::abs(p.normal.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  p.slide = 0.02 * p.normal.cross(a).normalized();
  PressDevice d(p);
  double fmin = INFINITY, worst = 0, last = -1;
  int switches = 0, node = -1;
  LockstepOptions o;
  o.duration = 1e6;
  o.frame_period = 0;
  run_lockstep(s, d, o, [&](const Rendered& x, const Sample&) {
    if (d.phase() != PressPhase::hold) {
      last = -1;
      return;
    }
    const double f = x.force.norm();
    if (last >= 0) worst = std::max(worst, std::abs(f - last));
    if (node >= 0 && x.contact_node != node) ++switches;
    node = x.contact_node;
    fmin = std::min(fmin, f);
    last = f;
  });
  ASSERT_TRUE(d.force_reached());
  std::printf(
      "disc pad, C body sliding: %d node switches, force >= %.3f N, largest change per "
      "step %.4f N (%.2f %%)\n",
      switches, fmin, worst, 100 * worst / fmin);
  EXPECT_GE(switches, 1);
  EXPECT_GT(fmin, 1.0);
  EXPECT_LE(worst, 0.035 * fmin);
}

TEST(Physics, ContactPadKeyIsChecked) {
  // "contact_pad" takes "vertices" or "disc"; anything else is an input error naming the file,
  // the JSON path and the choices.
  const std::string p =
      variant(read(proto("C")), "bad_pad", {{kDiscPad, "\"contact_pad\": \"discs\""}});
  try {
    prototypes::load_prototype(p);
    FAIL() << "contact_pad: discs accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(p), std::string::npos) << what;
    EXPECT_NE(what.find("$.model.contact_pad"), std::string::npos) << what;
    EXPECT_NE(what.find("disc"), std::string::npos) << what;
    EXPECT_NE(what.find("vertices"), std::string::npos) << what;
  }
}
