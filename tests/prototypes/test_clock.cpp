// The two clocks: lock-step (frames every 1/60 s of simulated time, same results as stepping
// the scene by hand) and real time (1 kHz haptic thread, graphics thread, double-buffered frames).
#include <gtest/gtest.h>

#include <cstring>

#include "engine/haptics/clock.hpp"
#include "prototypes/factory.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {
std::string proto(const std::string& id) {
  return std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + id + ".json";
}
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
