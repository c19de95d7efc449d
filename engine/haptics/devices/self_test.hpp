#pragma once
// Start-up self-test of a device: is it fast enough for 1 kHz haptics?
#include <string>

#include "engine/haptics/device.hpp"

namespace palplab::engine {

struct DeviceRate {
  double rate_hz = 0.0;   // fresh samples (hardware devices) or loop iterations per second
  long samples = 0;       // counted over `seconds`
  double seconds = 0.0;   // wall time measured
  bool hardware = false;  // counted the device's own samples (samples_received() >= 0)
};

// Reads the device in a 1 kHz loop (sleep until the next tick) for `seconds` of wall time and
// counts fresh samples (devices that receive them) or completed loop iterations (devices whose
// samples the simulator makes). Bounded: returns after `seconds`.
DeviceRate measure_device_rate(Device& device, double seconds = 0.25);

// Throws palplab::InputError naming the device, the measured and the required rate when the
// measured rate is below min_rate_hz (e.g. "device udp:5005 delivers 412 Hz, below the required
// 900 Hz (is the bridge running? lower the limit with --min-device-rate)").
DeviceRate require_device_rate(Device& device, const std::string& name, double min_rate_hz,
                               double seconds = 0.25);

}  // namespace palplab::engine
