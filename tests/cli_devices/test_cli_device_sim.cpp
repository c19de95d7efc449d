// `palplab device-sim` end to end: the scripted hand presses into prototype A over the UDP
// protocol while the real-time clock runs the scene here; then it goes silent and must get the
// force switched off. Bounded: the simulator runs 0.45 s.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>
#include "tests/cli_support.hpp"

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <future>
#include <nlohmann/json.hpp>
#include <string>

#include "engine/haptics/clock.hpp"
#include "engine/haptics/devices/udp_device.hpp"
#include "engine/haptics/press.hpp"
#include "prototypes/factory.hpp"

namespace e = palplab::engine;

namespace {
using Result = palplab::testing::CliResult;
Result run(const std::string& cmdline) {
  return palplab::testing::run_command(cmdline);
}
std::string proto(const std::string& id) {
  return std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + id + ".json";
}
}  // namespace

TEST(CliDeviceSim, ScriptedHandPressesAndGetsForceOffWhenSilent) {
  e::Scene scene = palplab::prototypes::build_scene(proto("A"));
  const auto& g = scene.geometry();
  const int node = e::press_node(g, "ovary_left");
  const Eigen::Vector3d p = g.V.row(node).transpose(), n = g.N.row(node).transpose();
  const Eigen::Vector3d out = p + 0.003 * n, in = p - 0.004 * n;
  const auto script = std::filesystem::temp_directory_path() /
                      ("palplab_sim_" + std::to_string(getpid()) + ".json");
  {
    nlohmann::json j = {{"waypoints",
                         {{0.0, out.x(), out.y(), out.z()},
                          {0.15, in.x(), in.y(), in.z()},
                          {0.3, in.x(), in.y(), in.z()}}}};
    std::ofstream(script) << j.dump();
  }
  e::UdpDevice dev({0, 0.002});
  const std::string cmd = std::string(PALPLAB_BINARY) + " device-sim --port " +
                          std::to_string(dev.port()) + " --script " + script.string() +
                          " --stop-after 0.3 --linger 0.1 --json";
  auto sim = std::async(std::launch::async, [&] { return run(cmd); });
  e::RealtimeOptions ro;
  ro.duration = 0.5;
  ro.frame_period = 0.0;
  const e::RealtimeStats st = e::run_realtime(scene, dev, ro);
  const Result r = sim.get();
  std::filesystem::remove(script);
  ASSERT_EQ(r.code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_GT(j["sent"].get<long>(), 150);      // ~300 at 1 kHz; a loaded machine sends fewer
  EXPECT_GT(j["received"].get<long>(), 150);  // one force per haptic step once connected
  // Hooke's law of prototype A at 4 mm: k * 0.004 (k = 500 N/m) = 2 N.
  EXPECT_NEAR(j["max_force"].get<double>(), 2.0, 0.25);
  const double off = j["force_off_after_stop_ms"].get<double>();
  ASSERT_GE(off, 0.0) << r.out;
  EXPECT_LE(off, 2.0 + st.period_max_us / 1e3 + 1.0);  // timeout + longest haptic period + 1 ms
  bool timeout = false;
  for (const auto& ev : dev.take_events()) timeout = timeout || ev.kind == "device_timeout";
  EXPECT_TRUE(timeout);
  EXPECT_EQ(run(std::string(PALPLAB_BINARY) + " device-sim --port 0").code, 2);
  EXPECT_EQ(
      run(std::string(PALPLAB_BINARY) + " device-sim --port 5000 --script /nonexistent.json").code,
      2);
}
