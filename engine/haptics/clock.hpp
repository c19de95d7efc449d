#pragma once
// The two clocks (docs/ARCHITECTURE.md). Both call the same Scene::step.
//
// Lock-step: one thread, simulated time, as fast as the CPU allows, deterministic. A graphics
// frame is taken every frame_period seconds of SIMULATED time.
//
// Real time: a haptic thread steps the scene at 1/dt Hz against the steady clock (sleep until the
// next tick; measured jitter), and publishes a graphics frame every frame_period into a double
// buffer; a graphics thread picks up the newest frame at its own rate (60 Hz) and hands it to the
// renderer callback. The scene and the device are touched by the haptic thread only; frames are
// the only shared state (mutex-protected swap), so the pair is data-race free (ThreadSanitizer).
#include <atomic>
#include <chrono>
#include <functional>
#include <vector>

#include "engine/haptics/device.hpp"
#include "engine/models/mass_spring.hpp"

namespace palplab::engine {

// What a renderer draws: the current surface and the perceivable state.
struct Frame {
  double t = 0.0;  // s, simulated time of the haptic step it was taken after
  long step = 0;   // haptic step index
  RowMatX3d V;     // current surface positions (m)
  RowMatX3i F;     // current surface faces
  Eigen::Vector3d device = Eigen::Vector3d::Zero();
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  bool contact = false, audio = false;
  double visible_deformation = 0.0;
};

struct LockstepOptions {
  double duration = 1.0;             // s of simulated time
  double frame_period = 1.0 / 60.0;  // s; <= 0: no frames
  // Start each step on a 1/dt tick of the steady clock (re-anchored when late, as
  // run_realtime), on this thread: a benchmark of a scene at the haptic rate in wall time
  // (e.g. a worker thread beside it) without run_realtime's threads or its real-time mode.
  bool paced = false;
};

// Runs duration/dt steps; on_step (optional) sees every step (copy the events you keep),
// on_frame (optional) every graphics frame. Stops early when device.finished(). Returns the
// number of steps taken.
long run_lockstep(Scene& scene, Device& device, const LockstepOptions& opt,
                  const std::function<void(const Rendered&, const Sample&)>& on_step = {},
                  const std::function<void(const Frame&)>& on_frame = {});

// The one place of palplab's timing statistics (probe, bench, the runner's loop times, the
// real-time clock's jitter). Quantiles are nearest rank on the sorted values: the q-quantile of
// n values is the value of rank round(q (n - 1)) (0-based), so p99 and max are values that
// occurred. The median is the usual sample median (the mean of the two middle values when n is
// even). Both return 0 for an empty set; q is clamped to [0, 1].
double quantile(std::vector<double> v, double q);
double median(std::vector<double> v);

// Median, 99th percentile and maximum of a set of durations (any unit); zeros when empty.
struct TimingSummary {
  double median = 0.0, p99 = 0.0, max = 0.0;
  long count = 0;
};
TimingSummary summarize_times(std::vector<double> times);

// Wraps a device and records the wall time between its read() and write(), which under
// run_lockstep is exactly the Scene::step in between (us). For probes, benchmarks and the
// runner's loop statistics. every > 1 times only steps 0, every, 2*every, ... (reading the
// clock twice per step is a measurable part of a cheap step; a systematic sample still
// estimates the median and p99).
class TimedDevice : public Device {
 public:
  TimedDevice(Device& inner, std::vector<double>& step_us, int every = 1)
      : inner_(inner), out_(step_us), every_(every < 1 ? 1 : every) {}
  DeviceInput read(double t) override;
  void write(const Rendered& r) override;
  bool finished() const override { return inner_.finished(); }
  std::vector<DeviceEvent> take_events() override { return inner_.take_events(); }
  long samples_received() const override { return inner_.samples_received(); }
  bool force_withheld() const override { return inner_.force_withheld(); }

 private:
  Device& inner_;
  std::vector<double>& out_;
  int every_;
  long step_ = 0;
  bool timing_ = false;
  std::chrono::steady_clock::time_point t0_;
};

struct RealtimeOptions {
  double duration = 1.0;             // s of wall time (= simulated time when on schedule)
  double frame_period = 1.0 / 60.0;  // s, frame publication and graphics rate
  // Runs on the haptic thread after every step (keep it short: copy what you log). Optional.
  std::function<void(const Rendered&, const Sample&)> on_step;
  // Set by another thread (window closed, Ctrl-C, device lost): the haptic loop ends after the
  // current step. The loop also ends when device.finished() (a replayed trace ran out).
  const std::atomic<bool>* stop = nullptr;
};

struct RealtimeStats {
  long steps = 0, frames_published = 0, frames_drawn = 0;
  // Haptic loop period (wall time between step starts), us.
  double period_median_us = 0, period_p99_us = 0, period_max_us = 0;
  double step_median_us = 0, step_p99_us = 0;  // wall time inside Scene::step
  long overruns = 0;                           // steps that started more than one period late
  bool stopped = false;  // ended early by opt.stop or device.finished() (steps < duration/dt)
};

// Blocks for opt.duration; on_frame runs on the graphics thread.
RealtimeStats run_realtime(Scene& scene, Device& device, const RealtimeOptions& opt,
                           const std::function<void(const Frame&)>& on_frame = {});

}  // namespace palplab::engine
