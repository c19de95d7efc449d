#include "engine/haptics/clock.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

namespace palplab::engine {

namespace {

void take_frame(const Scene& scene, const Rendered& r, const Eigen::Vector3d& x, long step,
                Frame& f) {
  scene.current_surface(f.V, f.F);
  f.t = r.t;
  f.step = step;
  f.device = x;
  f.force = r.force;
  f.contact = r.contact;
  f.audio = r.audio;
  f.visible_deformation = r.visible_deformation;
}

// Nearest rank on values already sorted.
double rank_of_sorted(const std::vector<double>& v, double q) {
  return v[static_cast<size_t>(std::clamp(q, 0.0, 1.0) * static_cast<double>(v.size() - 1) + 0.5)];
}

double median_of_sorted(const std::vector<double>& v) {
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// The next tick of a loop paced at `period`. On schedule: one period later. Late by more than
// a period (preempted): re-anchored instead of bursting through the missed ticks, so the hand
// never gets a train of back-to-back steps; simulated time then lags wall time.
void next_tick(std::chrono::steady_clock::time_point& next,
               std::chrono::steady_clock::duration period) {
  next += period;
  const auto now = std::chrono::steady_clock::now();
  if (now > next) next = now + period;
}

}  // namespace

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return rank_of_sorted(v, q);
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return median_of_sorted(v);
}

TimingSummary summarize_times(std::vector<double> times) {
  TimingSummary s;
  s.count = static_cast<long>(times.size());
  if (times.empty()) return s;
  std::sort(times.begin(), times.end());
  s.median = median_of_sorted(times);
  s.p99 = rank_of_sorted(times, 0.99);
  s.max = times.back();
  return s;
}

DeviceInput TimedDevice::read(double t) {
  const DeviceInput in = inner_.read(t);
  timing_ = step_++ % every_ == 0;
  if (timing_) t0_ = std::chrono::steady_clock::now();
  return in;
}

void TimedDevice::write(const Rendered& r) {
  if (timing_) {
    const auto t1 = std::chrono::steady_clock::now();
    out_.push_back(std::chrono::duration<double, std::micro>(t1 - t0_).count());
  }
  inner_.write(r);
}

long run_lockstep(Scene& scene, Device& device, const LockstepOptions& opt,
                  const std::function<void(const Rendered&, const Sample&)>& on_step,
                  const std::function<void(const Frame&)>& on_frame) {
  const long n = std::lround(opt.duration / scene.dt());
  // Frames on integer step boundaries (no drift): frame k >= 1 after step ceil(k * period / dt).
  auto frame_step = [&](long k) {
    return static_cast<long>(std::ceil(k * opt.frame_period / scene.dt() - 1e-9));
  };
  long frame_index = 1, next_frame = frame_step(1);
  Frame frame;
  using Clock = std::chrono::steady_clock;
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(scene.dt()));
  auto next = Clock::now();
  long k = 1;
  for (; k <= n && !device.finished(); ++k) {
    if (opt.paced) std::this_thread::sleep_until(next);
    const DeviceInput in = device.read(scene.time());
    const Rendered r = scene.step(in.position);
    device.write(r);
    if (on_step) on_step(r, scene.last_sample());
    if (on_frame && opt.frame_period > 0 && k >= next_frame) {
      take_frame(scene, r, in.position, k, frame);
      on_frame(frame);
      next_frame = frame_step(++frame_index);
    }
    if (opt.paced) next_tick(next, period);
  }
  return k - 1;
}

RealtimeStats run_realtime(Scene& scene, Device& device, const RealtimeOptions& opt,
                           const std::function<void(const Frame&)>& on_frame) {
  using Clock = std::chrono::steady_clock;
  RealtimeStats st;
  const long n = std::lround(opt.duration / scene.dt());
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(scene.dt()));
  const long frame_every = std::max(1L, std::lround(opt.frame_period / scene.dt()));

  // Double buffer: the haptic thread fills `back` alone, then swaps it with `front` under the
  // lock; the graphics thread copies `front` under the lock and draws its copy outside it.
  Frame back, front;
  bool fresh = false, done = false;
  std::mutex mu;
  std::condition_variable cv;
  long frames_published = 0;

  std::vector<double> periods, step_us;
  periods.reserve(n);
  step_us.reserve(n);
  long overruns = 0;
  long steps = 0;

  scene.set_realtime(true);  // back to lock-step when the loop ends (below)
  std::thread haptic([&] {
    auto next = Clock::now();
    auto last_start = next;
    for (long k = 1; k <= n; ++k) {
      if ((opt.stop && opt.stop->load(std::memory_order_relaxed)) || device.finished()) break;
      std::this_thread::sleep_until(next);
      const auto start = Clock::now();
      if (k > 1)
        periods.push_back(std::chrono::duration<double, std::micro>(start - last_start).count());
      if (start - next > period) ++overruns;
      last_start = start;
      const DeviceInput in = device.read(scene.time());
      const Rendered r = scene.step(in.position);
      device.write(r);
      if (opt.on_step) opt.on_step(r, scene.last_sample());
      steps = k;
      step_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - start).count());
      if (k % frame_every == 0) {
        take_frame(scene, r, in.position, k, back);
        {
          std::lock_guard<std::mutex> lock(mu);
          std::swap(back, front);
          fresh = true;
          ++frames_published;
        }
        cv.notify_one();
      }
      // (late ticks re-anchored: counted in overruns)
      next_tick(next, period);
    }
    {
      std::lock_guard<std::mutex> lock(mu);
      done = true;
    }
    cv.notify_one();
  });

  long drawn = 0;
  std::thread graphics([&] {
    Frame mine;
    while (true) {
      {
        std::unique_lock<std::mutex> lock(mu);
        cv.wait(lock, [&] { return fresh || done; });
        if (!fresh && done) break;
        mine = front;  // copy under the lock; draw outside it
        fresh = false;
      }
      if (on_frame) on_frame(mine);
      ++drawn;
    }
  });
  haptic.join();
  graphics.join();
  scene.set_realtime(false);
  st.steps = steps;
  st.stopped = steps < n;
  st.frames_published = frames_published;
  st.frames_drawn = drawn;
  const TimingSummary per = summarize_times(std::move(periods)), stp = summarize_times(step_us);
  st.period_median_us = per.median;
  st.period_p99_us = per.p99;
  st.period_max_us = per.max;
  st.step_median_us = stp.median;
  st.step_p99_us = stp.p99;
  st.overruns = overruns;
  return st;
}

}  // namespace palplab::engine
