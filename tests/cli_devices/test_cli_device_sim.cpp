// `palplab device-sim` end to end: the scripted hand presses into prototype A over the UDP
// protocol while the real-time clock runs the scene here; then it goes silent and must get the
// force switched off. Bounded: the simulator runs 0.45 s; the scene runs until it has exited
// (at most 20 s).
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>
#include "tests/cli_support.hpp"

#include <array>
#include <atomic>
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
  // The scene runs until the simulator process has exited (bounded at 20 s): a loaded machine can
  // take longer than the simulator's own 0.4 s to start the process, and a scene that had already
  // stopped would leave every datagram unanswered (received 0).
  std::atomic<bool> sim_done{false};
  auto sim = std::async(std::launch::async, [&] {
    Result res = run(cmd);
    sim_done = true;
    return res;
  });
  e::RealtimeOptions ro;
  ro.duration = 20.0;
  ro.frame_period = 0.0;
  ro.stop = &sim_done;
  const e::RealtimeStats st = e::run_realtime(scene, dev, ro);
  const Result r = sim.get();
  std::filesystem::remove(script);
  ASSERT_EQ(r.code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_GT(j["sent"].get<long>(), 150);      // ~300 at 1 kHz; a loaded machine sends fewer
  EXPECT_GT(j["received"].get<long>(), 150);  // one force per haptic step once connected
  // Hooke's law of prototype A at 4 mm: k * 0.004 (k = 500 N/m) = 2 N.
  EXPECT_NEAR(j["max_force"].get<double>(), 2.0, 0.25);
  // Its own send intervals at 1 kHz: the loop keeps to its schedule (a late tick is followed by
  // quicker ones), so the intervals average a period and their p99 is at least about one.
  const double gap_p99 = j["send_interval_p99_ms"].get<double>();
  EXPECT_GE(gap_p99, 0.9) << r.out;
  EXPECT_LE(gap_p99, j["send_interval_max_ms"].get<double>()) << r.out;
  const double off = j["force_off_after_stop_ms"].get<double>();
  ASSERT_GE(off, 0.0) << r.out;
  // The simulator times the force off by the kernel's arrival stamp (SO_TIMESTAMPNS), so its
  // own scheduling on a loaded machine does not count; the scene's does. The scene reads the last
  // position at its next step (up to one haptic period after it arrived), times out 2 ms after
  // that read, and sends the force off with the first step after the timeout (up to one more
  // period): timeout + twice the longest haptic period + 1 ms.
  EXPECT_LE(off, 2.0 + 2.0 * st.period_max_us / 1e3 + 1.0)
      << "longest haptic period " << st.period_max_us << " us\n"
      << r.out;
  bool timeout = false;
  for (const auto& ev : dev.take_events()) timeout = timeout || ev.kind == "device_timeout";
  EXPECT_TRUE(timeout);
  EXPECT_EQ(run(std::string(PALPLAB_BINARY) + " device-sim --port 0").code, 2);
  EXPECT_EQ(
      run(std::string(PALPLAB_BINARY) + " device-sim --port 5000 --script /nonexistent.json").code,
      2);
}

namespace {

// What a UdpDevice here received from one device-sim run: every read() until the simulator
// exits, answered with a zero force (so that --start-on-force starts its script).
struct Received {
  Result sim;
  std::vector<e::DeviceInput> samples;
};
Received receive_from_sim(const std::string& args) {
  e::UdpDevice dev({0, 0.05});
  const std::string cmd = std::string(PALPLAB_BINARY) + " device-sim --port " +
                          std::to_string(dev.port()) + " --json " + args;
  auto sim = std::async(std::launch::async, [&] { return run(cmd); });
  Received out;
  double t = 0.0;
  while (sim.wait_for(std::chrono::milliseconds(1)) != std::future_status::ready) {
    const e::DeviceInput in = dev.read(t);
    if (dev.samples_received() > 0) out.samples.push_back(in);
    e::Rendered r;
    r.t = t += 0.001;
    dev.write(r);
  }
  out.sim = sim.get();
  return out;
}

}  // namespace

// The stylus of a needle scene: a button mask and an orientation, from the script (buttons held
// from their time on, the axis interpolated and normalised) in type-3 datagrams.
TEST(CliDeviceSim, SendsTheScriptsButtonsAndStylusAxis) {
  const auto script = std::filesystem::temp_directory_path() /
                      ("palplab_sim_stylus_" + std::to_string(getpid()) + ".json");
  {
    nlohmann::json j = {{"waypoints", {{0.0, 0.0, 0.0, 0.01}, {0.3, 0.0, 0.0, 0.01}}},
                        {"buttons", {{0.1, 2}}},
                        {"axis", {{0.0, 0.0, 0.0, 2.0}, {0.2, 0.0, 3.0, 0.0}}}};
    std::ofstream(script) << j.dump();
  }
  const Received got = receive_from_sim("--script " + script.string() +
                                        " --start-on-force --duration 0.35 --wait 10");
  ASSERT_EQ(got.sim.code, 0) << got.sim.out;
  const auto j = nlohmann::json::parse(got.sim.out);
  EXPECT_EQ(j["datagram_type"].get<int>(), 3);
  EXPECT_EQ(j["button_changes"].get<long>(), 1);
  ASSERT_GT(got.samples.size(), 50u);
  // Buttons: 0 first, then 2 (the needle bit) until the end, never back.
  EXPECT_EQ(got.samples.front().buttons, 0u);
  EXPECT_EQ(got.samples.back().buttons, 2u);
  bool pressed = false;
  for (const auto& s : got.samples) {
    EXPECT_TRUE(s.buttons == 0u || s.buttons == 2u);
    if (pressed) {
      EXPECT_EQ(s.buttons, 2u);
    }
    pressed = pressed || s.buttons == 2u;
    EXPECT_FALSE(s.button);  // bit 0 never set
  }
  // Axis: +z (normalised from 2) at the start, +y (from 3) at the end, unit and in the y-z plane
  // with y, z >= 0 in between.
  EXPECT_LT((got.samples.front().stylus_axis - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  EXPECT_LT((got.samples.back().stylus_axis - Eigen::Vector3d::UnitY()).norm(), 1e-12);
  int between = 0;
  for (const auto& s : got.samples) {
    const Eigen::Vector3d& a = s.stylus_axis;
    EXPECT_NEAR(a.norm(), 1.0, 1e-12);
    EXPECT_EQ(a.x(), 0.0);
    EXPECT_GE(a.y(), 0.0);
    EXPECT_GE(a.z(), 0.0);
    between += a.y() > 0.05 && a.z() > 0.05;
  }
  EXPECT_GT(between, 10);  // ~200 samples on the way from +z to +y
  std::filesystem::remove(script);
}

TEST(CliDeviceSim, SendsAConstantMaskAndAxisFromTheOptions) {
  const Received got = receive_from_sim("--buttons 3 --axis 1 0 -1 --duration 0.15");
  ASSERT_EQ(got.sim.code, 0) << got.sim.out;
  EXPECT_EQ(nlohmann::json::parse(got.sim.out)["datagram_type"].get<int>(), 3);
  ASSERT_GT(got.samples.size(), 20u);
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 0, -1).normalized();
  for (const auto& s : got.samples) {
    EXPECT_EQ(s.buttons, 3u);
    EXPECT_TRUE(s.button);
    EXPECT_LT((s.stylus_axis - axis).norm(), 1e-12);
  }
  // Without an axis: type-1 datagrams, and the device reports no axis.
  const Received plain = receive_from_sim("--buttons 2 --duration 0.1");
  ASSERT_EQ(plain.sim.code, 0) << plain.sim.out;
  EXPECT_EQ(nlohmann::json::parse(plain.sim.out)["datagram_type"].get<int>(), 1);
  ASSERT_FALSE(plain.samples.empty());
  for (const auto& s : plain.samples) {
    EXPECT_EQ(s.buttons, 2u);
    EXPECT_EQ(s.stylus_axis, Eigen::Vector3d::Zero());
  }
}

// --wait without --start-on-force and --linger without --stop-after were silently ignored.
TEST(CliDeviceSim, FlagsWithoutTheirPartnerAreInputErrors) {
  const std::string sim = std::string(PALPLAB_BINARY) + " device-sim --port 5000 --duration 0.01 ";
  const Result w = run(sim + "--wait 5");
  EXPECT_EQ(w.code, 2) << w.out;
  EXPECT_NE(w.out.find("--wait: applies only with --start-on-force"), std::string::npos) << w.out;
  const Result l = run(sim + "--linger 0.5");
  EXPECT_EQ(l.code, 2) << l.out;
  EXPECT_NE(l.out.find("--linger: applies only with --stop-after"), std::string::npos) << l.out;
}

TEST(CliDeviceSim, RejectsBadButtonsAndAxes) {
  const std::string sim = std::string(PALPLAB_BINARY) + " device-sim --port 5000 --duration 0.01 ";
  const auto script = std::filesystem::temp_directory_path() /
                      ("palplab_sim_bad_" + std::to_string(getpid()) + ".json");
  auto with_script = [&](const nlohmann::json& j) {
    std::ofstream(script) << j.dump();
    return run(sim + "--script " + script.string());
  };
  const nlohmann::json w = {{0.0, 0.0, 0.0, 0.0}};
  struct Case {
    nlohmann::json script;
    std::string expect;
  };
  const std::vector<Case> cases = {
      {{{"waypoints", w}, {"axis", {{0.0, 0.0, 0.0, 0.0}}}}, "$.axis[0]"},
      {{{"waypoints", w}, {"axis", {{0.0, 1.0, 0.0}}}}, "$.axis[0]"},
      {{{"waypoints", w}, {"axis", {{0.2, 1.0, 0.0, 0.0}, {0.1, 0.0, 1.0, 0.0}}}}, "$.axis[1]"},
      {{{"waypoints", w}, {"buttons", {{0.0, -1}}}}, "$.buttons[0]"},
      {{{"waypoints", w}, {"buttons", {{0.0, 1.5}}}}, "$.buttons[0]"},
      {{{"waypoints", w}, {"buttons", nlohmann::json::array()}}, "$.buttons"},
      {{{"waypoints", w}, {"button", {{0.0, 2}}}}, "$.button"},
  };
  for (const auto& c : cases) {
    const Result r = with_script(c.script);
    EXPECT_EQ(r.code, 2) << c.script.dump();
    EXPECT_NE(r.out.find(c.expect), std::string::npos) << c.script.dump() << ": " << r.out;
  }
  // Review findings (2026-12-06, fourth): the script had its own reader: 1e999 was "internal
  // error" (exit 3), a repeated key was taken silently, a syntax error was the library's text
  // and a position of 1e300 m was sent. Now the one JSON reader: each FILE:LINE:COL: $.path.
  const std::vector<std::pair<std::string, std::string>> texts = {
      {R"({"waypoints": [[1e999, 0, 0, 0]]})", ":1:17: number 1e999 is out of range"},
      {R"({"waypoints": [[0, 0, 0, 0]], "waypoints": [[0, 1, 1, 1]]})",
       ":1:31: $.waypoints: duplicate key (also defined at line 1, column 2)"},
      {"{\"waypoints\": [[0, 0, 0,\n", ":2:1: invalid JSON: syntax error"},
      {R"({"waypoints": [[0, 0, 0, 1e300]]})",
       ":1:26: $.waypoints[0][3]: expected a value in [-10.0, 10.0] of [t, x, y, z] (s, m), got "
       "1e+300"},
      {R"({"waypoints": [[0, 0, 0, 0]], "buttons": [[0, 1e999]]})",
       ":1:47: number 1e999 is out of range"},
      {R"({"waypoints": [[0, 0, 0, 0], [0, 1, 0, 0]]})",
       ":1:31: $.waypoints[1][0]: expected times that increase (the previous entry is at 0.0 s), "
       "got 0.0"}};
  for (const auto& [text, expect] : texts) {
    std::ofstream(script) << text;
    const Result r = run(sim + "--script " + script.string());
    EXPECT_EQ(r.code, 2) << text << ": " << r.out;
    EXPECT_NE(r.out.find(script.string() + expect), std::string::npos) << text << ": " << r.out;
    EXPECT_EQ(r.out.find("duplicate key", r.out.find("duplicate key") + 1), std::string::npos)
        << "one duplicate, said once: " << r.out;
  }
  EXPECT_EQ(run(sim + "--axis 0 0 0").code, 2);
  EXPECT_EQ(run(sim + "--axis 1 0").code, 2);
  EXPECT_EQ(run(sim + "--buttons -1").code, 2);
  EXPECT_EQ(run(sim + "--buttons 4294967296").code, 2);
  {
    std::ofstream(script) << nlohmann::json({{"waypoints", w}, {"buttons", {{0.0, 2}}}}).dump();
    EXPECT_EQ(run(sim + "--script " + script.string() + " --buttons 2").code, 2);
  }
  std::filesystem::remove(script);
}

// NaN and negative --duration/--stop-after fell back to the defaults without a word (-1 was the
// "not given" marker, and every comparison with NaN is false), and "--start-on-force --wait nan"
// waited for ever when no forces came. Every numeric flag is exit 2 naming it and the value; the
// runs are bounded by `timeout`, so a hang shows as exit 124, not as a stuck test.
TEST(CliDeviceSim, NumericFlagsRefuseNanNegativeAndOutOfRange) {
  namespace t = palplab::testing;
  const auto dir = t::scratch_dir("device_sim_flags");
  auto sim = [&](const std::string& args) {
    return t::run_shell(
        "timeout -k 5 20 " + std::string(PALPLAB_BINARY) + " device-sim --port 5000 " + args, dir);
  };
  struct Case {
    std::string args, flag, shown;  // the flag and what the message must show
  };
  const std::vector<Case> cases = {
      {"--duration nan", "--duration", "'nan'"},
      {"--duration -1", "--duration", "'-1'"},
      {"--duration 0", "--duration", "(0, 3600]"},
      {"--duration inf", "--duration", "'inf'"},
      {"--stop-after nan", "--stop-after", "'nan'"},
      {"--stop-after -3", "--stop-after", "'-3'"},
      {"--duration 0.05 --rate nan", "--rate", "'nan'"},
      {"--duration 0.05 --rate 0", "--rate", "[1, 10000]"},
      {"--stop-after 0.05 --linger nan", "--linger", "'nan'"},
      {"--stop-after 0.05 --linger -1", "--linger", "[0, 10]"},
      {"--start-on-force --wait nan", "--wait", "'nan'"},
      {"--start-on-force --wait inf", "--wait", "'inf'"},
      {"--start-on-force --wait -1", "--wait", "'-1'"},
      {"--start-on-force --wait 0", "--wait", "(0, 3600]"},
      // The stop was silently clamped to the end of the run.
      {"--duration 1 --stop-after 5", "--stop-after", "5 s is after the end of the run at 1 s"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.args);
    const t::CliResult r = sim(c.args);
    t::expect_exit2(r, {c.flag + ":", c.shown});
    EXPECT_TRUE(r.out.empty()) << r.out;  // refused before sending anything
  }
  // The port: a number beyond 64 bits was clamped by the integer parse.
  t::expect_exit2(t::run_palplab("device-sim --port 99999999999999999999", dir),
                  {"--port", "[1, 65535]", "'99999999999999999999'"});
  // Without --duration the run lasts to the script's end + 0.1 s: a --stop-after beyond it, or
  // a script that ends before 0 - 0.1 s, names the script's end.
  const std::string script = (dir / "s.json").string();
  std::ofstream(script) << R"({"waypoints": [[0, 0, 0, 0], [0.2, 0, 0, 0]]})";
  t::expect_exit2(sim("--script " + script + " --stop-after 0.5"),
                  {"--stop-after", "after the end of the run at 0.3 s", "give --duration"});
  std::ofstream(script) << R"({"waypoints": [[-5, 0, 0, 0]]})";
  t::expect_exit2(sim("--script " + script),
                  {script, "the script ends at -5 s", "or give --duration"});
  // A valid bounded run still runs (nobody answers on a free port: exit 1, nothing received;
  // not 5000, where another test's palplab may be listening).
  const t::CliResult ok =
      t::run_shell("timeout -k 5 20 " + std::string(PALPLAB_BINARY) + " device-sim --port " +
                       std::to_string(t::free_udp_port()) +
                       " --duration 0.05 --stop-after 0.02 --linger 0 --json",
                   dir);
  EXPECT_EQ(ok.code, 1) << ok.err;
  const auto j = nlohmann::json::parse(ok.out);
  EXPECT_GT(j["sent"].get<long>(), 0);
  EXPECT_EQ(j["stopped_at"].get<double>(), 0.02);
  // No force off came: null, and said so in the text (it was -1 ms, a time; review 2026-12-06,
  // fourth).
  EXPECT_TRUE(j["force_off_after_stop_ms"].is_null()) << ok.out;
  const t::CliResult text = t::run_shell(
      "timeout -k 5 20 " + std::string(PALPLAB_BINARY) + " device-sim --port " +
          std::to_string(t::free_udp_port()) + " --duration 0.05 --stop-after 0.02 --linger 0",
      dir);
  EXPECT_NE(text.out.find("; no force off came after the last position"), std::string::npos)
      << text.out;
  std::filesystem::remove_all(dir);
}
