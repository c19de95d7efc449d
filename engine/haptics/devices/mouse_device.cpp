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

DeviceInput MouseDevice::read(double /*t*/) {
  double v[4];
  in_.load(v);
  DeviceInput in;
  in.position = {v[0], v[1], v[2]};
  in.button = v[3] != 0.0;
  return in;
}

}  // namespace palplab::engine
