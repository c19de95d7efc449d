#include "engine/haptics/devices/monitored_device.hpp"

#include <algorithm>

namespace palplab::engine {

DeviceInput MonitoredDevice::read(double t) {
  const DeviceInput in = inner_.read(t);
  const double p[3] = {in.position.x(), in.position.y(), in.position.z()};
  pos_.store(p);
  return in;
}

Eigen::Vector3d MonitoredDevice::last_position() const {
  double p[3];
  pos_.load(p);
  return {p[0], p[1], p[2]};
}

void MonitoredDevice::write(const Rendered& r) {
  inner_.write(r);
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

RenderedSummary MonitoredDevice::last_rendered() const {
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
