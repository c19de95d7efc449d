#include "engine/haptics/device.hpp"

#include <stdexcept>

namespace palplab::engine {

ScriptedDevice::ScriptedDevice(std::vector<std::pair<double, Eigen::Vector3d>> waypoints)
    : path_(std::move(waypoints)) {
  if (path_.empty()) throw std::invalid_argument("ScriptedDevice: no waypoints");
  for (size_t k = 1; k < path_.size(); ++k)
    if (!(path_[k].first > path_[k - 1].first))
      throw std::invalid_argument("ScriptedDevice: waypoint times must increase");
  forces_.reserve(1 << 16);
}

DeviceInput ScriptedDevice::read(double t) {
  DeviceInput in;
  if (t <= path_.front().first) {
    in.position = path_.front().second;
  } else if (t >= path_.back().first) {
    in.position = path_.back().second;
  } else {
    size_t k = 1;
    while (path_[k].first < t) ++k;
    const double a = (t - path_[k - 1].first) / (path_[k].first - path_[k - 1].first);
    in.position = (1.0 - a) * path_[k - 1].second + a * path_[k].second;
  }
  return in;
}

void ScriptedDevice::write(const Rendered& r) {
  forces_.push_back(r.force);
}

}  // namespace palplab::engine
