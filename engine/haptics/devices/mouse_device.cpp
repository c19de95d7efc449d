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

void MouseDevice::write(const Rendered& r) {
  const double f = r.force.norm();
  peak_ = r.contact ? std::max(peak_, f) : 0.0;
  const double v[8] = {r.t,
                       r.force.x(),
                       r.force.y(),
                       r.force.z(),
                       r.contact ? 1.0 : 0.0,
                       r.audio ? 1.0 : 0.0,
                       static_cast<double>(r.contact_region),
                       peak_};
  out_.store(v);
}

RenderedSummary MouseDevice::last_rendered() const {
  double v[8];
  out_.load(v);
  RenderedSummary s;
  s.t = v[0];
  s.force = {v[1], v[2], v[3]};
  s.contact = v[4] != 0.0;
  s.audio = v[5] != 0.0;
  s.contact_region = static_cast<int>(v[6]);
  s.peak_force = v[7];
  return s;
}

}  // namespace palplab::engine
