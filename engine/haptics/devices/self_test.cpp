#include "engine/haptics/devices/self_test.hpp"

#include <chrono>
#include <cmath>
#include <sstream>
#include <thread>

#include "common/input_error.hpp"

namespace palplab::engine {

DeviceRate measure_device_rate(Device& device, double seconds) {
  using Clock = std::chrono::steady_clock;
  DeviceRate r;
  r.hardware = device.samples_received() >= 0;
  // What arrived before the window (a bridge that started earlier, a burst after a stall) is
  // read first and not counted: the rate is of what arrives while it is measured.
  device.read(0.0);
  const long before = device.samples_received();
  const auto t0 = Clock::now();
  const auto end =
      t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  const auto period = std::chrono::microseconds(1000);
  auto next = t0;
  long loops = 0;
  while (true) {
    std::this_thread::sleep_until(next);
    if (Clock::now() >= end) break;
    device.read(0.0);
    ++loops;
    next += period;
  }
  r.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  r.samples = r.hardware ? device.samples_received() - before : loops;
  r.rate_hz = r.seconds > 0 ? r.samples / r.seconds : 0.0;
  device.take_events();  // timeouts while nobody was pressing are not part of any session
  return r;
}

DeviceRate require_device_rate(Device& device, const std::string& name, double min_rate_hz,
                               double seconds) {
  const DeviceRate r = measure_device_rate(device, seconds);
  if (r.rate_hz < min_rate_hz) {
    std::ostringstream s;
    s << "device " << name << " delivers " << std::lround(r.rate_hz) << " Hz (" << r.samples
      << (r.hardware ? " samples" : " loop iterations") << " in " << r.seconds
      << " s), below the required " << min_rate_hz << " Hz"
      << (r.hardware ? " (is the bridge running and sending at 1 kHz?)" : " (machine overloaded?)")
      << "; lower the limit with --min-device-rate";
    throw InputError(s.str());
  }
  return r;
}

}  // namespace palplab::engine
