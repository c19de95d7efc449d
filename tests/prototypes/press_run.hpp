#pragma once
// The tests' presses: the one press script (engine/haptics/press.hpp) on the press node of a
// region, driven by the one lock-step loop (engine/haptics/clock.hpp). No test writes a press
// loop of its own.
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

}  // namespace palplab::engine::testing
