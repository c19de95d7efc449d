// The press script's hold force control (engine/haptics/press.hpp) on the prototypes where the
// stiffness under the probe changes: the benches' sliding press (engine::sliding_press, 2.5 N,
// 2 cm/s over 80 % of the region's long axis) on the left ovary of C and of B, and the still
// presses that must be as before.
//
// Measured (issue 9; tests/engine/test_press.cpp has the analytic spring), former fixed-gain
// integral control (gain 0.2 / the approach's secant) -> now, peak force of the hold:
//   C ovary slide 3.95 N (+58 %) -> 2.78 N (+11 %); B 2.97 N (+19 %) -> 2.80 N (+12 %);
//   D 3.23 N (+29 %) -> 2.96 N (+18 %); A 2.53 N both. Share of the hold within 10 %:
//   97 -> 89 % (C), 95 -> 91 % (B): the 10 cm/s rate limit on pressing in makes the device lag
//   where the surface falls away along the press axis faster (off the tip, down the flank).
//   Ablation: the rate limit alone (fixed gain) C 3.58 N (+43 %); the stiffness estimate alone
//   (no rate limit) C 3.09 N (+23 %), D 3.47 N (+39 %, and it lost the contact for a step);
//   both together bound it. Most of what is left are force jumps
//   at contact-node changes, which no controller sees coming.
// Then (issue 9, the force's steps while sliding): a sliding hold moves its depth along the force
// it feels instead of the start normal (press.hpp), the contact tracker bounds the proxy's step
// by the projection's gain times the device's tangential step (contact.cpp) and C's exterior is
// blended in over 16 steps (far_field.hpp). Peak and share within 10 % of the ovary slides:
//   C 2.78 N, 89 % -> 2.503 N, 99.4 %; B 2.80 N, 91 % -> 2.500 N, 100 %; D 2.96 N, 93 % ->
//   2.500 N, 97 %; A 2.53 N, 90 % -> 2.500 N, 100 %. Largest step of the force (vector): see
//   SlideForceStepsBelowWeberHalf.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "engine/haptics/clock.hpp"
#include "engine/haptics/press.hpp"
#include "prototypes/factory.hpp"
#include "tests/prototypes/press_run.hpp"

using namespace palplab;
using namespace palplab::engine;
using palplab::engine::testing::Hold;
using palplab::engine::testing::measure_hold;

namespace {

Hold run(const std::string& id, const PressSpec& spec) {
  Scene s =
      prototypes::build_scene(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + id + ".json");
  return measure_hold(s, spec);
}

PressSpec slide_on(const std::string& id, const std::string& region) {
  Scene s =
      prototypes::build_scene(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + id + ".json");
  return sliding_press(s.geometry(), region, 2.5, 0.02);
}

}  // namespace

TEST(PressControl, SlidingPressOffTheOvaryTipOfCStaysBounded) {
  // The slide moves off the tip's cap onto the ovary's flank. While the hold pushed along the
  // start normal, the force along that axis fell away (the device followed the flank 3 cm deep)
  // and the contact node changed ~25 times, each change a step in the force: peak +11 % (+58 %
  // before the adaptive hold), 89 % of the steps within 10 %, the rest dips where the surface
  // fell away along the axis faster than the 10 cm/s rate limit let the device follow. Pushing
  // along the force it feels: peak +0.1 %, 99.4 % within 10 %. Bounds kept: peak <= +20 %,
  // >= 85 % within 10 %.
  const Hold h = run("C", slide_on("C", "ovary_left"));
  std::printf("C ovary slide: peak %.3f N, %.1f %% of the hold within 10 %%\n", h.peak,
              100 * h.in_band);
  EXPECT_LE(h.peak, 1.20 * 2.5);
  EXPECT_GE(h.in_band, 0.85);
}

TEST(PressControl, SlidingPressOnTheOvaryOfBStaysBounded) {
  const Hold h = run("B", slide_on("B", "ovary_left"));
  std::printf("B ovary slide: peak %.3f N, %.1f %% of the hold within 10 %%\n", h.peak,
              100 * h.in_band);
  EXPECT_LE(h.peak, 1.15 * 2.5);  // measured +0.0 % (+12 % pushing along the start normal)
  EXPECT_GE(h.in_band, 0.85);     // measured 100 % (91 %)
}

TEST(PressControl, StillPressesReachAndHoldTheTargetAsBefore) {
  // The approach is unchanged (the same time to force to the step); the hold settles within 1 %
  // of the target 0.1 s after it (measured <= 0.4 %, as before: 0.4 % on C's body). C's time
  // is that of its disc pad (0.448 s; 0.410 s with the vertex pads, whose press at the ovary
  // node is 11 % stiffer: test_refine_pad.cpp).
  for (const char* id : {"A", "B", "C"}) {
    Scene s =
        prototypes::build_scene(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + id + ".json");
    const PressSpec p =
        press_at(s.geometry(), s.geometry().region_node("ovary_left"), 2.5, 0.5, 0.0);
    const Hold h = run(id, p);
    SCOPED_TRACE(id);
    EXPECT_NEAR(h.time_to_force, std::string(id) == "C" ? 0.448 : 0.351, 1.5e-3);
    EXPECT_LE(h.settled, 0.01);
    EXPECT_LE(h.peak, 1.01 * 2.5);
  }
}

TEST(PressControl, SlidBodyPressWithdrawsOffTheSurfaceBelowTheDeviceLimit) {
  // The benches' sliding press on C's body and left ovary (2.5 N, 2 cm/s over 80 % of the
  // region's long axis).
  // - Body: the slide ends where the body's surface faces another way than at the start: there
  //   the depth along the start normal is 2.6 cm (the controller followed the flank), and
  //   backing out along the start normal drove the probe into the flank (the contact depth grew
  //   3.5 -> 12 mm, the force 2.4 -> 8.5 N, the device's limit, for 30 ms of the "withdrawal").
  //   A slid press now lifts off along the force it feels.
  // - Left ovary: lifting off along the force for the whole depth (which includes the slide's
  //   path) carried the probe off the ovary and 4 cm on into the horn (5.8 N during the
  //   "withdrawal"; bench_engine_step --sliding). A slid press now ends its withdrawal
  //   start_offset out of contact.
  // The force may only fall during the withdrawal (bound: the force at its start + 2 %, for
  // the tissue's own relaxation); it ends out of contact and the device limit is never reached.
  Scene s = prototypes::build_scene(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/C.json");
  for (const char* region : {"body", "ovary_left"}) {
    s.reset();
    const PressSpec spec = sliding_press(s.geometry(), region, 2.5, 0.02);
    PressDevice d(spec);
    double f_start = -1.0, f_withdraw = 0.0, f_max = 0.0;
    long limited = 0, contact_steps_after = 0;
    bool contact_at_end = true, left = false;
    run_lockstep(s, d, {.duration = spec.hold + 3.0, .frame_period = 0.0},
                 [&](const Rendered& r, const Sample&) {
                   const double f = r.force.norm();
                   f_max = std::max(f_max, f);
                   for (const Event& e : r.events) limited += e.kind == EventKind::force_limited;
                   if (d.phase() == PressPhase::withdraw || d.phase() == PressPhase::release) {
                     if (f_start < 0.0)
                       f_start = f;  // the step that began the withdrawal
                     else
                       f_withdraw = std::max(f_withdraw, f);
                     left = left || !r.contact;
                     contact_steps_after += left && r.contact;  // touching again
                   }
                   contact_at_end = r.contact;
                 });
    std::printf(
        "C %s slide: max force %.3f N, withdrawal starts at %.3f N, then at most %.3f N; %ld "
        "steps in contact again after leaving\n",
        region, f_max, f_start, f_withdraw, contact_steps_after);
    EXPECT_TRUE(d.finished()) << region;
    EXPECT_GT(f_start, 0.0) << region;
    EXPECT_LE(f_withdraw, 1.02 * f_start) << region;
    EXPECT_EQ(contact_steps_after, 0) << region;
    EXPECT_EQ(limited, 0) << region;
    EXPECT_LT(f_max, s.config().contact.force_limit) << region;
    EXPECT_FALSE(contact_at_end) << region;
  }
}

TEST(PressControl, SlideForceStepsBelowWeberHalf) {
  // The benches' sliding press (2.5 N, 2 cm/s over 80 % of the left ovary's long axis) on every
  // prototype: the largest step-to-step change of the rendered force (the vector) during the
  // hold. At 1 kHz a step of force is felt as a tap; the force Weber fraction is ~7 %, so a
  // step must stay below half of it, 3.5 % of the target (0.0875 N).
  // Measured (issue 9), before -> now: A 0.132 -> 0.020 N, B 0.421 -> 0.017 N,
  // C 0.821 -> 0.058 N, D 0.674 -> 0.043 N. Before, the hold pushed in along the start normal,
  // which on the ovaries' flanks moved the device sideways at the 10 cm/s rate limit (5x the
  // slide), the tracker moved the contact point up to 4x that per step (catching up with a
  // projection millimetres away at 1 % of an edge a step) and C adopted a re-centred scope's
  // exterior in one step (0.82 N). Leaving one change out (measured): depth along the start
  // normal: A 0.13, B 0.32, C 0.30, D 0.36 N; the former tracker bound: C 0.33, D 0.52 N.
  for (const char* id : {"A", "B", "C", "D"}) {
    const Hold h = run(id, slide_on(id, "ovary_left"));
    std::printf(
        "%s ovary slide: largest step %.4f N at %.3f s, peak %.3f N, %.1f %% within 10 %%\n", id,
        h.max_step, h.max_step_t, h.peak, 100 * h.in_band);
    SCOPED_TRACE(id);
    EXPECT_LE(h.max_step, 0.035 * 2.5);
  }
}
