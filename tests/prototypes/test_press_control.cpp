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

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "engine/haptics/clock.hpp"
#include "engine/haptics/press.hpp"
#include "prototypes/factory.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {

struct Hold {
  double peak = 0.0;     // N, largest force during the hold
  double in_band = 0.0;  // fraction of hold steps within 10 % of the target
  double settled = 0.0;  // largest |F / F* - 1| from 0.1 s after the target (still presses)
  double time_to_force = -1.0;
};

Hold run(const std::string& id, const PressSpec& spec) {
  Scene s =
      prototypes::build_scene(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + id + ".json");
  PressDevice d(spec);
  Hold h;
  long steps = 0, in = 0;
  run_lockstep(s, d, {.duration = spec.hold + 2.0, .frame_period = 0.0},
               [&](const Rendered& r, const Sample&) {
                 if (!d.force_reached() || d.phase() != PressPhase::hold) return;
                 const double f = r.force.norm(), rel = f / spec.force - 1.0;
                 h.peak = std::max(h.peak, f);
                 ++steps;
                 in += std::abs(rel) <= 0.1;
                 if (r.t > d.time_to_force() + 0.1) h.settled = std::max(h.settled, std::abs(rel));
               });
  h.in_band = steps ? static_cast<double>(in) / static_cast<double>(steps) : 0.0;
  h.time_to_force = d.time_to_force();
  return h;
}

PressSpec slide_on(const std::string& id, const std::string& region) {
  Scene s =
      prototypes::build_scene(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + id + ".json");
  return sliding_press(s.geometry(), region, 2.5, 0.02);
}

}  // namespace

TEST(PressControl, SlidingPressOffTheOvaryTipOfCStaysBounded) {
  // The slide moves off the tip's cap onto the ovary's flank: the force along the press axis
  // falls away (the device follows the flank 3 cm deep) and the contact node changes ~25 times,
  // each change a step in the force. Bound: peak <= +20 % (measured +11 %, before +58 %); the
  // force within 10 % on >= 85 % of the hold's steps (measured 89 %; the rest are dips where
  // the surface falls away along the axis faster than the 10 cm/s rate limit lets the device
  // follow, and force drops of the model at a constant depth).
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
  EXPECT_LE(h.peak, 1.15 * 2.5);  // measured +12 %, before +19 %
  EXPECT_GE(h.in_band, 0.85);     // measured 91 %
}

TEST(PressControl, StillPressesReachAndHoldTheTargetAsBefore) {
  // The approach is unchanged (the same time to force to the step); the hold settles within 1 %
  // of the target 0.1 s after it (measured <= 0.4 %, as before: 0.4 % on C's body).
  for (const char* id : {"A", "B", "C"}) {
    Scene s =
        prototypes::build_scene(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + id + ".json");
    const PressSpec p =
        press_at(s.geometry(), s.geometry().region_node("ovary_left"), 2.5, 0.5, 0.0);
    const Hold h = run(id, p);
    SCOPED_TRACE(id);
    EXPECT_NEAR(h.time_to_force, std::string(id) == "C" ? 0.410 : 0.351, 1.5e-3);
    EXPECT_LE(h.settled, 0.01);
    EXPECT_LE(h.peak, 1.01 * 2.5);
  }
}

TEST(PressControl, SlidBodyPressWithdrawsOffTheSurfaceBelowTheDeviceLimit) {
  // The benches' sliding press on C's body (2.5 N, 2 cm/s over 80 % of its long axis). The
  // slide ends where the body's surface faces another way than at the start: there the depth
  // along the start normal is 2.6 cm (the controller followed the flank), and backing out along
  // the start normal drove the probe into the flank (the contact depth grew 3.5 -> 12 mm, the
  // force 2.4 -> 8.5 N, the device's limit, for 30 ms of the "withdrawal"). A slid press now
  // lifts off along the force it feels: the force may only fall during the withdrawal (bound:
  // the force at its start + 2 %, for the tissue's own relaxation), it ends out of contact and
  // the device limit is never reached.
  Scene s = prototypes::build_scene(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/C.json");
  const PressSpec spec = sliding_press(s.geometry(), "body", 2.5, 0.02);
  PressDevice d(spec);
  double f_start = -1.0, f_withdraw = 0.0, f_max = 0.0;
  long limited = 0;
  bool contact_at_end = true;
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
                 }
                 contact_at_end = r.contact;
               });
  std::printf("C body slide: max force %.3f N, withdrawal starts at %.3f N, then at most %.3f N\n",
              f_max, f_start, f_withdraw);
  EXPECT_TRUE(d.finished());
  EXPECT_GT(f_start, 0.0);
  EXPECT_LE(f_withdraw, 1.02 * f_start);
  EXPECT_EQ(limited, 0);
  EXPECT_LT(f_max, s.config().contact.force_limit);
  EXPECT_FALSE(contact_at_end);
}
