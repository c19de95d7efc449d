#pragma once
// The one scripted press (used by `palplab probe`, `render --press`, the benchmarks and tests):
// a device that starts `start_offset` outside a surface point, moves in along the inward normal
// at `approach_speed` until the rendered force reaches `force`, holds that force for `hold`
// seconds (integral control of the depth, gain from the stiffness it measured on the way in),
// withdraws at `withdraw_speed` to the start point and stays there for `release` seconds.
// It is a Device, so the lock-step and the real-time clocks drive it the same way; it reports
// finished() when the script is over.
#include <Eigen/Core>
#include <string>

#include "engine/haptics/device.hpp"

namespace palplab::engine {

struct PressSpec {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    // m, rest surface point pressed
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // outward unit normal there
  double force = 2.5;                                 // N, target device force
  double hold = 1.0;                                  // s at the target
  double release = 1.0;                               // s after the withdrawal
  double start_offset = 0.002;                        // m outside the surface
  double approach_speed = 0.02;                       // m/s
  double withdraw_speed = 0.05;                       // m/s
  double max_depth = 0.06;                            // m: give up pressing deeper than this
  double max_approach_time = 10.0;                    // s: give up pressing after this
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
  bool force_reached() const { return time_to_force_ >= 0.0; }
  double time_to_force() const { return time_to_force_; }  // s from the start, -1 if never
  double depth() const { return depth_; }                  // m below the rest surface now
  const PressSpec& spec() const { return spec_; }

 private:
  Eigen::Vector3d position() const { return spec_.point - depth_ * spec_.normal; }
  PressSpec spec_;
  PressPhase phase_ = PressPhase::approach;
  double depth_ = 0.0;
  double t_ = 0.0;            // s of script time
  double phase_start_ = 0.0;  // s, when the current phase began
  double time_to_force_ = -1.0;
  double contact_depth_ = -1.0;  // depth at which force first appeared (m), -1 before
  double gain_ = 0.0;            // m/N per step of the hold controller
};

// The press node of a region (the node nearest the region's centroid) or a node index given
// as digits; throws std::invalid_argument naming the regions when `what` is neither.
int press_node(const SceneGeometry& g, const std::string& what);
// A press spec at surface node `node` of g (its rest position and outward normal).
PressSpec press_at(const SceneGeometry& g, int node, double force, double hold, double release);

}  // namespace palplab::engine
