#pragma once
// The mouse as the haptic device (`palplab view`): the window thread sets where the contact point
// is (from the cursor ray and the press depth); the haptic thread reads it at 1 kHz. The hand-over
// is a seqlock of atomics, so neither thread ever waits for the other (data-race free under
// TSan). What was rendered goes back through MonitoredDevice.
#include <Eigen/Core>
#include <atomic>

#include "engine/haptics/device.hpp"

namespace palplab::engine {

// A value of a few doubles handed from one writer thread to one reader thread without locks: the
// writer bumps the sequence to odd, stores, bumps to even; the reader retries while the
// sequence is odd or changed. N doubles, relaxed atomics inside the fences.
template <int N>
class SeqlockValue {
 public:
  void store(const double (&v)[N]) {
    const unsigned s = seq_.load(std::memory_order_relaxed);
    seq_.store(s + 1, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_release);
    for (int i = 0; i < N; ++i) data_[i].store(v[i], std::memory_order_relaxed);
    seq_.store(s + 2, std::memory_order_release);
  }
  void load(double (&v)[N]) const {
    while (true) {
      const unsigned s0 = seq_.load(std::memory_order_acquire);
      if (s0 & 1u) continue;
      for (int i = 0; i < N; ++i) v[i] = data_[i].load(std::memory_order_relaxed);
      std::atomic_thread_fence(std::memory_order_acquire);
      if (seq_.load(std::memory_order_relaxed) == s0) return;
    }
  }

 private:
  std::atomic<unsigned> seq_{0};
  std::atomic<double> data_[N] = {};
};

class MouseDevice : public Device {
 public:
  explicit MouseDevice(const Eigen::Vector3d& start);
  // Window thread.
  void set_position(const Eigen::Vector3d& x, bool button);
  // The tool of a multi-tool scene (devices/tool_switch.hpp): the needle while `needle` (the
  // window latches it with the N key), inserted along `axis` (unit; the mouse has no stylus, so
  // the window sends the camera's view direction through the contact point).
  void set_tool(bool needle, const Eigen::Vector3d& axis);
  void stop() { stop_.store(true, std::memory_order_release); }
  // Haptic thread.
  DeviceInput read(double t) override;
  void write(const Rendered& r) override {}
  bool finished() const override { return stop_.load(std::memory_order_acquire); }

 private:
  SeqlockValue<4> in_;    // x, y, z, button
  SeqlockValue<4> tool_;  // needle (0/1), axis x, y, z
  SeqlockValue<8> out_;   // t, fx, fy, fz, contact, audio, region, peak
  double peak_ = 0.0;     // haptic thread only
  std::atomic<bool> stop_{false};
};

}  // namespace palplab::engine
