#include "engine/haptics/devices/tool_switch.hpp"

#include "engine/haptics/scene_config.hpp"

namespace palplab::engine {

ToolSwitchDevice::ToolSwitchDevice(Device& inner, Scene& scene)
    : inner_(inner),
      scene_(scene),
      tool_(scene.tool()),
      axis_(scene.config().needle.axis.normalized()) {}

DeviceInput ToolSwitchDevice::read(double t) {
  DeviceInput in = inner_.read(t);
  const std::string tool = (in.buttons & kNeedleToolButton) ? "needle" : "finger";
  Eigen::Vector3d axis = axis_;
  const double n = in.stylus_axis.norm();
  if (in.stylus_axis.allFinite() && n > 1e-9) axis = in.stylus_axis / n;
  if (tool != tool_ || axis != axis_) {
    scene_.set_tool(tool, axis);
    tool_ = tool;
    axis_ = axis;
  }
  return in;
}

}  // namespace palplab::engine
