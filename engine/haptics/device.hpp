#pragma once
// The haptic device seen by the simulator: position in, rendered force out, buttons. A person's
// stylus, a virtual participant, a recorded trace: all drive a Scene through this interface
// (one virtual call per haptic step, never per node).
#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "engine/haptics/scene.hpp"

namespace palplab::engine {

struct DeviceInput {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // m, haptic contact point
  bool button = false;                                 // = buttons & 1
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  // m/s, as the device measures it (0 if not)
  unsigned buttons = 0;                                // bit i = button i pressed
  // Unit stylus axis, handle -> tip, in the organ's frame; zero = the device reports none.
  // Read only by multi-tool scenes (the needle's insertion direction, devices/tool_switch.hpp).
  Eigen::Vector3d stylus_axis = Eigen::Vector3d::Zero();
};

// Bit of DeviceInput::buttons that selects the needle of a multi-tool scene while set (level, not
// an edge: a lost sample cannot leave the tool wrong); clear = the finger. A device with a
// button bar sends it held or latched; the palpation window latches it with the N key.
inline constexpr unsigned kNeedleToolButton = 1u << 1;

// Something that happened at the device (not in the simulation), for the session's event log:
// "device_timeout" (no fresh sample for longer than the timeout; the force was switched off),
// "device_resumed" (samples arrive again), "device_gap" (value = sequence numbers lost).
struct DeviceEvent {
  double t = 0.0;  // s, simulated time of the step in which it was noticed
  std::string kind;
  double value = 0.0;
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
  // Device events since the last call (moved out). Devices without any return none.
  // take_events() and samples_received() may be called from another thread than read() and
  // write() (a real-time session's writer thread polls them while the haptic thread steps):
  // implementations that have state behind them must make them thread-safe.
  virtual std::vector<DeviceEvent> take_events() { return {}; }
  // Fresh samples received from hardware so far, for the start-up rate self-test
  // (devices/self_test.hpp); -1 for devices whose samples are made by the simulator's own loop.
  virtual long samples_received() const { return -1; }
  // True when the last write() gave the hand no force although the simulator rendered one (a
  // UDP device timed out sends "force off"): the session's log records what the hand got.
  virtual bool force_withheld() const { return false; }
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
