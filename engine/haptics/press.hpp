#pragma once
// The one scripted press (used by `palplab probe`, `render --press`, the benchmarks and tests):
// a device that starts `start_offset` outside a surface point, moves in along the inward normal
// at `approach_speed` until the rendered force reaches `force`, holds that force for `hold`
// seconds, withdraws at `withdraw_speed` to the start point and stays there for `release` seconds.
// Force control during the hold: integral control of the depth, d += 0.3 (F* - F) / k, with k
// an online estimate of the local stiffness (second differences of force and depth, each
// measurement bounded to a factor 2, geometric filter, within 1/10..10x the approach's secant)
// and the depth's rate bounded (hold_speed_in/out); the depth is the integrator's state, so
// bounding it (and its rate) is the anti-windup.
// It is a Device, so the lock-step and the real-time clocks drive it the same way; it reports
// finished() when the script is over.
//
// Variants (every scripted press of palplab is one of these, never a loop of its own):
//   depth > 0          position control: in to that depth, held there (no force target)
//   force_error != 0   the force is judged with that relative error (a person's Weber noise)
//   stop_at_target     the script ends on the step the target is reached (a demonstration)
//   slide != 0         the contact point moves tangentially at that velocity while holding
//                      (a sliding press across an organ; the hold's depth then follows the
//                      rendered force's direction)
//   hold_depth         the hold keeps the depth at which the force target was reached
//                      (a trajectory fixed by the force, then position control)
//   segments           a script of holds and slides after the target (below), in place of
//                      the single hold: e.g. press to 2.5 N, hold 0.1 s, slide 1 cm at
//                      2 cm/s, hold 0.1 s, withdraw
#include <Eigen/Core>
#include <string>
#include <vector>

#include "engine/haptics/device.hpp"

namespace palplab::engine {

// One part of a multi-segment press (PressSpec::segments): a hold of `hold` seconds when `by`
// is zero, else a slide of the contact point by `by` (m) at `speed` (m/s), lasting
// |by| / speed. The depth is held (force or position control, as in the single hold) while
// the segment runs.
struct PressSegment {
  double hold = 0.0;                             // s
  Eigen::Vector3d by = Eigen::Vector3d::Zero();  // m, displacement of the contact point
  double speed = 0.02;                           // m/s along `by`

  static PressSegment hold_for(double seconds) { return {seconds, Eigen::Vector3d::Zero(), 0.02}; }
  static PressSegment slide_by(const Eigen::Vector3d& by, double speed) { return {0.0, by, speed}; }
  bool is_slide() const { return !by.isZero(0.0); }
  double duration() const { return is_slide() ? by.norm() / speed : hold; }  // s
};

struct PressSpec {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    // m, rest surface point pressed
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // outward unit normal there
  double force = 2.5;                                 // N, target device force
  double hold = 1.0;                                  // s at the target
  double release = 1.0;                               // s after the withdrawal
  // m outside the surface; negative: the script starts that far inside (with depth control
  // and start_offset = -depth, a step input to the held depth)
  double start_offset = 0.002;
  double approach_speed = 0.02;     // m/s
  double withdraw_speed = 0.05;     // m/s
  double max_depth = 0.06;          // m: give up pressing deeper than this
  double max_approach_time = 10.0;  // s: give up pressing after this
  // m/s, rate limits of the depth while the force is held (force control): in at most
  // hold_speed_in, back out at most hold_speed_out (backing off a force overshoot is the safe
  // direction, so it may be faster)
  double hold_speed_in = 0.1;
  double hold_speed_out = 0.5;
  // Position control instead of a force target: press to this depth (m below the rest surface,
  // > 0) at approach_speed and hold it; `force` is then ignored. 0 = force control.
  double depth = 0.0;
  // Relative error of the force judgement: the target counts as reached when
  // |F| (1 + force_error) >= force (> -1; 0 = exact).
  double force_error = 0.0;
  // End the script on the step the target is reached (or given up): no hold, no withdrawal.
  bool stop_at_target = false;
  // m/s, velocity of the contact point along the surface during the hold; zero = a still press.
  // The offset moves along this fixed vector; the hold's depth changes of a sliding press (this,
  // or a slide segment) are made along the force rendered on the step before (the contact
  // normal where the probe is), not along `normal` (issue 9: on the ovary tips pushing in along
  // the start normal slid the device down the flank at the 10 cm/s rate limit, 5x the slide,
  // 3 cm deep along `normal`, and the force jumped by up to 0.67 N a step). A still press keeps
  // its depth along `normal`. Its offset is kept while withdrawing. A press that
  // slid withdraws along the direction of the force rendered on its last hold step (the
  // surface's normal where the probe is, not `normal` where it started: on a curved organ the
  // start normal may point into the surface there), over the same distance and at the same
  // speed; a still press withdraws along `normal`.
  Eigen::Vector3d slide = Eigen::Vector3d::Zero();
  // Under force control, keep the depth at which the target was reached during the hold (and
  // the segments) instead of holding the force: the device trajectory then depends on the
  // model only through that one depth (replayable on another model).
  bool hold_depth = false;
  // A script of holds and slides run in order once the target is reached, in place of `hold`
  // and `slide`; then the withdrawal. Timing: the k-th step after the step that reached the
  // target ends tau = k dt later and belongs to the segment i whose interval
  // (T_i, T_i + D_i] holds tau (T_i: the durations before it); a slide's offset there is
  // by_i (tau - T_i) / D_i, so its first step has moved speed dt and its last step lands
  // exactly on by_i; a hold of D s lasts D / dt steps. The first step after the last segment
  // is the first of the withdrawal. Offsets are kept while withdrawing.
  std::vector<PressSegment> segments;
};

enum class PressPhase { approach, hold, withdraw, release, done };
const char* to_string(PressPhase p);

class PressDevice : public Device {
 public:
  explicit PressDevice(const PressSpec& spec);
  DeviceInput read(double t) override;
  void write(const Rendered& r) override;
  bool finished() const override { return phase_ == PressPhase::done; }

  PressPhase phase() const { return phase_; }
  // The target (force, or depth under position control) was reached.
  bool force_reached() const { return time_to_force_ >= 0.0; }
  double time_to_force() const { return time_to_force_; }  // s (scene time), -1 if never
  double depth() const { return depth_; }                  // m below the rest surface now
  const PressSpec& spec() const { return spec_; }
  // N/m, the hold controller's current estimate of the local stiffness dF/d(depth) (0 before
  // the target is reached under force control).
  double stiffness_estimate() const { return stiffness_; }
  // Index of the segment (PressSpec::segments) the next step belongs to; -1 before the target
  // and after the last segment. A change of it after a write marks the last step of a segment.
  int segment() const { return segment_; }
  Eigen::Vector3d offset() const { return offset_; }  // m, slid along the surface so far

 private:
  Eigen::Vector3d position() const { return spec_.point + offset_ - depth_ * spec_.normal + lift_; }
  // Enters the withdrawal after a step that rendered force f (N, on the hand).
  void begin_withdraw(double t, const Eigen::Vector3d& f);
  bool target_reached(double f) const;
  void reach_target(double t, double f, double dt);
  // Moves to the next step of the segments (offset, segment_); false after the last one.
  bool next_segment_step(double dt);
  PressSpec spec_;
  PressPhase phase_ = PressPhase::approach;
  double depth_ = 0.0;
  double t_ = 0.0;            // s of script time
  double phase_start_ = 0.0;  // s, when the current phase began
  double time_to_force_ = -1.0;
  double contact_depth_ = -1.0;  // depth at which force first appeared (m), -1 before
  // One step of the hold's force control after a step rendered `force` (N, on the hand) at depth_.
  void hold_force(const Eigen::Vector3d& force, double dt);
  bool slides_ = false;        // the script slides (PressSpec::slide or a slide segment)
  double stiffness_ = 0.0;     // N/m, the hold controller's local stiffness estimate
  double stiffness_in_ = 0.0;  // N/m, its first value (the approach's secant)
  double hist_d_[3] = {0, 0, 0}, hist_f_[3] = {0, 0, 0};  // m, N: the last three hold steps
  int hist_n_ = 0;                                        // hold steps seen
  Eigen::Vector3d offset_ = Eigen::Vector3d::Zero();      // m, slid along the surface so far
  // m, what a slid press's withdrawal moved the device off the line along `normal`, and the
  // unit direction it withdraws along (see PressSpec::slide)
  Eigen::Vector3d lift_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d out_dir_ = Eigen::Vector3d::Zero();
  double clear_ = 0.0;  // m, a slid press's withdrawal: moved since its last step in contact
  int segment_ = -1;
  long segment_step_ = 0;                                   // steps since the target
  Eigen::Vector3d segment_base_ = Eigen::Vector3d::Zero();  // offset at the target
};

// The press node of a region (the node nearest the region's centroid) or a node index given
// as digits; throws std::invalid_argument naming the regions when `what` is neither.
int press_node(const SceneGeometry& g, const std::string& what);
// A press spec at surface node `node` of g (its rest position and outward normal).
PressSpec press_at(const SceneGeometry& g, int node, double force, double hold, double release);
// A sliding press across `region` along its longest extent (the principal axis of its rest
// vertices): at the surface node nearest the point 10 % along that axis, to `force` N, then
// holding the force while the contact point slides at `speed` m/s over 80 % of the region's
// length (PressSpec::slide, along the axis projected on the tangent plane). `length` (optional)
// receives the region's extent along the axis (m). Throws std::invalid_argument for an unknown
// region.
PressSpec sliding_press(const SceneGeometry& g, const std::string& region, double force,
                        double speed, double* length = nullptr);

}  // namespace palplab::engine
