#pragma once
// MonitoredDevice: wraps the device of a real-time session and publishes what the haptic thread
// last rendered (force, contact, cue) for the window thread's force bar and cue flash, lock-free
// (seqlock), so the haptic thread never waits for the window.
#include "engine/haptics/devices/mouse_device.hpp"

namespace palplab::engine {

// What the haptic thread last rendered, for the window's force bar and cue flash.
struct RenderedSummary {
  double t = 0.0;                                   // s
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  // N
  bool contact = false, audio = false;
  int contact_region = -1;
  double peak_force = 0.0;  // N, largest force magnitude since the last contact start
};

class MonitoredDevice : public Device {
 public:
  explicit MonitoredDevice(Device& inner) : inner_(inner) {}
  DeviceInput read(double t) override;
  void write(const Rendered& r) override;
  bool finished() const override { return inner_.finished(); }
  std::vector<DeviceEvent> take_events() override { return inner_.take_events(); }
  long samples_received() const override { return inner_.samples_received(); }
  bool force_withheld() const override { return inner_.force_withheld(); }
  // Window thread.
  RenderedSummary last_rendered() const;
  Eigen::Vector3d last_position() const;

 private:
  Device& inner_;
  SeqlockValue<8> out_;  // t, fx, fy, fz, contact, audio, region, peak
  SeqlockValue<3> pos_;  // device position of the last step
  double peak_ = 0.0;    // haptic thread only
};

}  // namespace palplab::engine
