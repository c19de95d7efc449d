#pragma once
// The haptic device seen by the simulator: position in, rendered force out, buttons. A person's
// stylus, a virtual participant, a recorded trace: all drive a Scene through this interface
// (one virtual call per haptic step, never per node).
#include <Eigen/Core>
#include <utility>
#include <vector>

#include "engine/haptics/scene.hpp"

namespace palplab::engine {

struct DeviceInput {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // m, haptic contact point
  bool button = false;
};

class Device {
 public:
  virtual ~Device() = default;
  // Where the hand is at simulated time t (s).
  virtual DeviceInput read(double t) = 0;
  // What the simulator rendered for the last step (force on the hand, cues).
  virtual void write(const Rendered& r) = 0;
  // A scripted device may end before the clock's duration; run_lockstep stops then.
  virtual bool finished() const { return false; }
};

// A device that follows a piecewise-linear path through (t, x) waypoints (s, m), holding the
// last position after the last waypoint, and records the forces it is given. For tests and
// scripted checks.
class ScriptedDevice : public Device {
 public:
  explicit ScriptedDevice(std::vector<std::pair<double, Eigen::Vector3d>> waypoints);
  DeviceInput read(double t) override;
  void write(const Rendered& r) override;
  const std::vector<Eigen::Vector3d>& forces() const { return forces_; }

 private:
  std::vector<std::pair<double, Eigen::Vector3d>> path_;
  std::vector<Eigen::Vector3d> forces_;
};

}  // namespace palplab::engine
