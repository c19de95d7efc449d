#pragma once
// A person's tool choice carried from the device to a multi-tool scene (model "needle"), on the
// haptic thread: each read() of the device sets the scene's tool before the step that uses the
// sample, exactly as the virtual trainee's commands do in a lock-step session
// (protocols/needle_session.cpp): Scene::set_tool whenever the tool or the axis changes, so the
// scene logs `tool_changed` the same way.
//
//   tool  = "needle" while DeviceInput::buttons has kNeedleToolButton, else "finger";
//   axis  = DeviceInput::stylus_axis when the device reports one (finite, non-zero), else the
//           last axis used (at the start the prototype's model.axis). The needle model locks the
//           axis at the entry point, so turning the stylus inside the tissue does not bend it.
#include <string>

#include "engine/haptics/device.hpp"
#include "engine/haptics/scene.hpp"

namespace palplab::engine {

class ToolSwitchDevice : public Device {
 public:
  // `scene` must outlive this device and be stepped only by the thread that calls read().
  ToolSwitchDevice(Device& inner, Scene& scene);
  DeviceInput read(double t) override;
  void write(const Rendered& r) override { inner_.write(r); }
  bool finished() const override { return inner_.finished(); }
  std::vector<DeviceEvent> take_events() override { return inner_.take_events(); }
  long samples_received() const override { return inner_.samples_received(); }
  bool force_withheld() const override { return inner_.force_withheld(); }

 private:
  Device& inner_;
  Scene& scene_;
  std::string tool_;
  Eigen::Vector3d axis_;
};

}  // namespace palplab::engine
