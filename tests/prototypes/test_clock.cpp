// The two clocks: lock-step (frames every 1/60 s of simulated time, same results as stepping
// the scene by hand) and real time (1 kHz haptic thread, graphics thread, double-buffered frames).
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>

#include "engine/haptics/clock.hpp"
#include "prototypes/factory.hpp"
#include "tests/prototypes/prototype_text.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {
using palplab::engine::testing::proto;
// Press the ovary: 2 mm outside to 8 mm inside in 0.5 s, hold, withdraw.
ScriptedDevice press_device(const Scene& s) {
  const auto& g = s.geometry();
  const int node = g.region_node("ovary_left");
  const Eigen::Vector3d p = g.V.row(node).transpose(), n = g.N.row(node).transpose();
  return ScriptedDevice(
      {{0.0, p + 0.002 * n}, {0.5, p - 0.008 * n}, {0.7, p - 0.008 * n}, {0.9, p + 0.002 * n}});
}
}  // namespace

TEST(Clock, LockstepFramesAndSameResultAsManualStepping) {
  Scene a = prototypes::build_scene(proto("C1"));
  ScriptedDevice dev = press_device(a);
  std::vector<Eigen::Vector3d> forces;
  std::vector<double> frame_t;
  long verts = 0;
  const long n = run_lockstep(
      a, dev, {1.0, 1.0 / 60.0},
      [&](const Rendered& r, const Sample& s) {
        forces.push_back(r.force);
        EXPECT_EQ(s.t, r.t);
      },
      [&](const Frame& f) {
        frame_t.push_back(f.t);
        verts = std::max(verts, static_cast<long>(f.V.rows()));
        EXPECT_EQ(f.F.maxCoeff() < f.V.rows(), true);
      });
  EXPECT_EQ(n, 1000);
  EXPECT_EQ(forces.size(), 1000u);
  EXPECT_EQ(dev.forces().size(), 1000u);
  EXPECT_EQ(frame_t.size(), 60u);  // 1 s at 60 Hz of simulated time
  for (size_t k = 1; k < frame_t.size(); ++k)
    EXPECT_NEAR(frame_t[k] - frame_t[k - 1], 1.0 / 60, 1.001e-3);
  EXPECT_GT(verts, a.geometry().V.rows());  // the surface, refined under the press
  // Same bits as stepping the scene by hand with the same positions.
  Scene b = prototypes::build_scene(proto("C1"));
  ScriptedDevice dev2 = press_device(b);
  double fmax = 0;
  for (long k = 0; k < 1000; ++k) {
    const Rendered r = b.step(dev2.read(b.time()).position);
    ASSERT_EQ(std::memcmp(r.force.data(), forces[k].data(), sizeof(double) * 3), 0) << k;
    fmax = std::max(fmax, r.force.norm());
  }
  EXPECT_GT(fmax, 1.0);
}

TEST(Clock, RealtimeHapticAndGraphicsThreads) {
  Scene s = prototypes::build_scene(proto("B"));
  ScriptedDevice dev = press_device(s);
  long frames = 0;
  double last_t = -1;
  bool ordered = true;
  const RealtimeStats st = run_realtime(s, dev, {0.5, 1.0 / 60.0}, [&](const Frame& f) {
    ++frames;
    ordered = ordered && f.t > last_t;
    last_t = f.t;
  });
  EXPECT_EQ(st.steps, 500);
  EXPECT_EQ(dev.forces().size(), 500u);
  EXPECT_EQ(st.frames_published, 500 / 17);
  EXPECT_EQ(st.frames_drawn, frames);
  EXPECT_GE(frames, 1);
  EXPECT_LE(frames, st.frames_published);
  EXPECT_TRUE(ordered);  // the graphics thread never sees an older frame after a newer one
  // 1 kHz: never faster than the period (no catch-up bursts); loose upper bound, the machine
  // is shared.
  EXPECT_GT(st.period_median_us, 990.0);
  EXPECT_LT(st.period_median_us, 3000.0);
  std::printf(
      "real time: period median %.1f us, p99 %.1f us, max %.1f us, overruns %ld, step "
      "median %.2f us, frames %ld/%ld\n",
      st.period_median_us, st.period_p99_us, st.period_max_us, st.overruns, st.step_median_us,
      st.frames_drawn, st.frames_published);
}

// The one place of the timing statistics: nearest-rank quantiles, the usual median.
TEST(Clock, QuantileIsNearestRankAndMedianTheSampleMedian) {
  const std::vector<double> odd = {5, 1, 4, 2, 3}, even = {4, 1, 3, 2};
  EXPECT_EQ(median(odd), 3.0);
  EXPECT_EQ(median(even), 2.5);         // mean of the two middle values
  EXPECT_EQ(quantile(even, 0.5), 3.0);  // rank round(0.5 * 3) = 2 (0-based) of 1 2 3 4
  EXPECT_EQ(quantile(odd, 0.0), 1.0);
  EXPECT_EQ(quantile(odd, 1.0), 5.0);
  EXPECT_EQ(quantile(odd, 7.0), 5.0);   // clamped
  EXPECT_EQ(quantile(odd, 0.24), 2.0);  // rank round(0.96) = 1
  EXPECT_EQ(median({}), 0.0);
  EXPECT_EQ(quantile({}, 0.99), 0.0);
  std::vector<double> v;
  for (int i = 1; i <= 1000; ++i) v.push_back(1001 - i);  // 1000 .. 1, unsorted order
  const TimingSummary t = summarize_times(v);
  EXPECT_EQ(t.count, 1000);
  EXPECT_EQ(t.median, 500.5);
  EXPECT_EQ(t.p99, 990.0);  // rank round(0.99 * 999) = 989 -> value 990
  EXPECT_EQ(t.max, 1000.0);
  EXPECT_EQ(summarize_times({}).count, 0);
}

// TimedDevice(every = 8) times steps 0, 8, 16, ... and passes everything else through.
TEST(Clock, TimedDeviceSamplesEveryNthStep) {
  Scene s = prototypes::build_scene(proto("A"));
  ScriptedDevice dev = press_device(s);
  std::vector<double> all, some;
  TimedDevice every(dev, all), eighth(every, some, 8);
  const long n = run_lockstep(s, eighth, {0.1, 0.0});
  EXPECT_EQ(n, 100);
  EXPECT_EQ(all.size(), 100u);
  EXPECT_EQ(some.size(), 13u);  // steps 0, 8, ..., 96
  EXPECT_EQ(dev.forces().size(), 100u);
  for (double us : some) EXPECT_GE(us, 0.0);
}

// Paced lock-step (LockstepOptions::paced, the benches' loop at the haptic rate): each step
// starts on a 1/dt tick, so 300 steps of 1 ms take at least 0.299 s of wall time (sleep_until
// never wakes early), and the results are the unpaced loop's to the bit (same thread, same
// scene calls).
TEST(Clock, PacedLockstepKeepsTheHapticRateAndTheResults) {
  std::vector<Eigen::Vector3d> forces[2];
  for (int paced = 0; paced < 2; ++paced) {
    Scene s = prototypes::build_scene(proto("A"));
    ScriptedDevice dev = press_device(s);
    ASSERT_EQ(s.dt(), 1e-3);
    LockstepOptions o;
    o.duration = 0.3;
    o.frame_period = 0.0;
    o.paced = paced;
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_EQ(
        run_lockstep(s, dev, o,
                     [&](const Rendered& r, const Sample&) { forces[paced].push_back(r.force); }),
        300);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (paced) {
      EXPECT_GE(wall, 0.299);
    }
  }
  ASSERT_EQ(forces[0].size(), forces[1].size());
  for (size_t k = 0; k < forces[0].size(); ++k)
    ASSERT_EQ(std::memcmp(forces[0][k].data(), forces[1][k].data(), sizeof(double) * 3), 0) << k;
  EXPECT_GT(forces[0].back().norm() + forces[0][250].norm(), 0.0);  // the press reached A
}
