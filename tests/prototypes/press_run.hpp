#pragma once
// The tests' presses: the one press script (engine/haptics/press.hpp) on the press node of a
// region, driven by the one lock-step loop (engine/haptics/clock.hpp). No test writes a press
// loop of its own.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "engine/haptics/clock.hpp"
#include "engine/haptics/press.hpp"

namespace palplab::engine::testing {

// What a step rendered, with its events copied (Rendered::events is only valid until the next
// step).
struct Rec : Rendered {
  std::vector<Event> ev;
};

// A position-controlled press of `region`: 2 mm outside its press node, in along the inward
// normal at 2 cm/s to `depth` (m), held `hold` s, out at `withdraw_speed` (m/s), then left there.
inline PressSpec depth_press(const Scene& s, const std::string& region, double depth, double hold,
                             double withdraw_speed = 0.05) {
  PressSpec p = press_at(s.geometry(), s.geometry().region_node(region), 1.0, hold, 1e3);
  p.depth = depth;
  p.withdraw_speed = withdraw_speed;
  return p;
}

// `steps` lock-step haptic steps of `spec` on s (fewer only if the script ends first); `paced`:
// each step on a 1/dt tick of the steady clock (LockstepOptions::paced), as in real time.
inline std::vector<Rec> run_press(Scene& s, const PressSpec& spec, int steps, bool paced = false) {
  PressDevice d(spec);
  std::vector<Rec> out;
  out.reserve(steps);
  run_lockstep(s, d, {.duration = steps * s.dt(), .frame_period = 0.0, .paced = paced},
               [&](const Rendered& r, const Sample&) {
                 Rec x;
                 static_cast<Rendered&>(x) = r;
                 x.ev.assign(r.events.begin(), r.events.end());
                 x.events = {};
                 out.push_back(std::move(x));
               });
  return out;
}

// What the hold of a force-controlled press rendered (PressControl tests, the slide's numbers in
// docs/ARCHITECTURE.md "Press force control": one code path for both).
struct Hold {
  double peak = 0.0;     // N, largest force during the hold
  double in_band = 0.0;  // fraction of hold steps within 10 % of the target
  double settled = 0.0;  // largest |F / F* - 1| from 0.1 s after the target (still presses)
  double time_to_force = -1.0;
  double max_step = 0.0;   // N, largest |F_k - F_(k-1)| (vectors) between two hold steps
  double max_step_t = -1;  // s, when it happened (the later step)
  long steps = 0;          // hold steps
  std::vector<Eigen::Vector3d> force;  // N, every hold step's force (with `keep`)
};

// Runs `spec` on s in lock-step (spec.hold + 2 s) and measures its hold: the steps after the
// one that reached the target while the script holds (slides included), up to the step before
// the withdrawal. `keep`: Hold::force gets each hold step's force.
inline Hold measure_hold(Scene& s, const PressSpec& spec, bool keep = false) {
  PressDevice d(spec);
  Hold h;
  long in = 0;
  bool prev_hold = false;
  Eigen::Vector3d prev = Eigen::Vector3d::Zero();
  run_lockstep(s, d, {.duration = spec.hold + 2.0, .frame_period = 0.0},
               [&](const Rendered& r, const Sample&) {
                 const bool hold = d.force_reached() && d.phase() == PressPhase::hold;
                 if (hold) {
                   const double f = r.force.norm(), rel = f / spec.force - 1.0;
                   h.peak = std::max(h.peak, f);
                   ++h.steps;
                   in += std::abs(rel) <= 0.1;
                   if (r.t > d.time_to_force() + 0.1)
                     h.settled = std::max(h.settled, std::abs(rel));
                   if (prev_hold && (r.force - prev).norm() > h.max_step) {
                     h.max_step = (r.force - prev).norm();
                     h.max_step_t = r.t;
                   }
                   if (keep) h.force.push_back(r.force);
                 }
                 prev_hold = hold;
                 prev = r.force;
               });
  h.in_band = h.steps ? static_cast<double>(in) / static_cast<double>(h.steps) : 0.0;
  h.time_to_force = d.time_to_force();
  return h;
}

}  // namespace palplab::engine::testing
