#include "engine/haptics/devices/mouse_device.hpp"

#include <algorithm>

namespace palplab::engine {

MouseDevice::MouseDevice(const Eigen::Vector3d& start) {
  set_position(start, false);
}

void MouseDevice::set_position(const Eigen::Vector3d& x, bool button) {
  const double v[4] = {x.x(), x.y(), x.z(), button ? 1.0 : 0.0};
  in_.store(v);
}

void MouseDevice::set_tool(bool needle, const Eigen::Vector3d& axis) {
  const double v[4] = {needle ? 1.0 : 0.0, axis.x(), axis.y(), axis.z()};
  tool_.store(v);
}

DeviceInput MouseDevice::read(double /*t*/) {
  double v[4], w[4];
  in_.load(v);
  tool_.load(w);
  DeviceInput in;
  in.position = {v[0], v[1], v[2]};
  in.button = v[3] != 0.0;
  in.buttons = (in.button ? 1u : 0u) | (w[0] != 0.0 ? kNeedleToolButton : 0u);
  in.stylus_axis = {w[1], w[2], w[3]};
  return in;
}

}  // namespace palplab::engine
