// The device layer: UDP protocol encoding, the UDP device against an in-test bridge (sequence
// numbers, localhost, timeouts -> force off within 5 ms and an event), the start-up rate
// self-test, and trace record -> replay giving bit-identical sessions. Every loop is bounded.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <limits>
#include <thread>

#include "common/input_error.hpp"
#include "engine/haptics/clock.hpp"
#include "engine/haptics/devices/self_test.hpp"
#include "engine/haptics/devices/trace_device.hpp"
#include "engine/haptics/devices/udp_device.hpp"
#include "engine/haptics/press.hpp"
#include "prototypes/factory.hpp"

namespace e = palplab::engine;
using Clock = std::chrono::steady_clock;

namespace {

std::string proto(const std::string& id) {
  return std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + id + ".json";
}

// A bridge program's end of the protocol, in the test.
struct Bridge {
  int fd = -1;
  sockaddr_in to{};
  std::uint32_t seq = 0;
  explicit Bridge(int port) {
    fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_in self{};
    self.sin_family = AF_INET;
    self.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::bind(fd, reinterpret_cast<sockaddr*>(&self), sizeof self);
    to.sin_family = AF_INET;
    to.sin_port = htons(static_cast<std::uint16_t>(port));
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  }
  ~Bridge() { ::close(fd); }
  void send(const Eigen::Vector3d& x, std::uint32_t s, unsigned buttons = 0) {
    e::UdpPosition m;
    m.seq = s;
    m.x = x;
    m.buttons = buttons;
    const auto b = e::encode(m);
    ::sendto(fd, b.data(), b.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to);
  }
  void send(const Eigen::Vector3d& x) { send(x, ++seq); }
  std::optional<e::UdpForce> receive(double wait_s = 0.0) {
    const auto end = Clock::now() + std::chrono::duration<double>(wait_s);
    std::uint8_t buf[256];
    do {
      const ssize_t n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
      if (n >= 0) return e::decode_force(buf, static_cast<size_t>(n));
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    } while (Clock::now() < end);
    return std::nullopt;
  }
};

}  // namespace

TEST(UdpProtocol, RoundTripAndLittleEndianLayout) {
  e::UdpPosition p;
  p.seq = 0x01020304u;
  p.buttons = 5;
  p.t_device = 1.25;
  p.x = {0.1, -0.2, 0.3};
  p.v = {1, 2, 3};
  const auto b = e::encode(p);
  ASSERT_EQ(b.size(), 72u);
  EXPECT_EQ(b[0], 0x50);  // 'P'
  EXPECT_EQ(b[3], 0x44);  // 'D'
  EXPECT_EQ(b[4], 1);     // version
  EXPECT_EQ(b[6], 1);     // type position
  EXPECT_EQ(b[8], 0x04);  // seq, least significant byte first
  EXPECT_EQ(b[11], 0x01);
  const auto q = e::decode_position(b.data(), b.size());
  ASSERT_TRUE(q);
  EXPECT_EQ(q->seq, p.seq);
  EXPECT_EQ(q->buttons, 5u);
  EXPECT_EQ(q->t_device, 1.25);
  EXPECT_EQ(q->x, p.x);
  EXPECT_EQ(q->v, p.v);
  // Malformed: wrong size, magic, type.
  EXPECT_FALSE(e::decode_position(b.data(), 71));
  auto bad = b;
  bad[0] = 0;
  EXPECT_FALSE(e::decode_position(bad.data(), bad.size()));
  EXPECT_FALSE(e::decode_force(b.data(), b.size()));
  e::UdpForce f;
  f.seq = 7;
  f.ack = 9;
  f.flags = e::kUdpContact | e::kUdpForceOff;
  f.t = 0.5;
  f.f = {0, 0, 2.5};
  const auto fb = e::encode(f);
  ASSERT_EQ(fb.size(), 64u);
  const auto g = e::decode_force(fb.data(), fb.size());
  ASSERT_TRUE(g);
  EXPECT_EQ(g->ack, 9u);
  EXPECT_EQ(g->flags, f.flags);
  EXPECT_EQ(g->f, f.f);
}

TEST(UdpDevice, PositionInForceOutWithSequenceNumbers) {
  e::UdpDevice dev({0, 0.5});
  ASSERT_GT(dev.port(), 0);
  Bridge br(dev.port());
  br.send({0.01, 0.02, 0.03}, 10, 1);
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  e::DeviceInput in = dev.read(0.0);
  EXPECT_EQ(in.position, Eigen::Vector3d(0.01, 0.02, 0.03));
  EXPECT_TRUE(in.button);
  e::Rendered r;
  r.t = 0.001;
  r.force = {0, 0, 1.5};
  r.contact = true;
  dev.write(r);
  auto f = br.receive(0.5);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->ack, 10u);
  EXPECT_EQ(f->f, r.force);
  EXPECT_EQ(f->flags & e::kUdpContact, e::kUdpContact);
  EXPECT_EQ(f->flags & e::kUdpForceOff, 0u);
  // A late datagram (older sequence) is ignored; a jump reports the lost ones.
  br.send({9, 9, 9}, 9);
  br.send({0.04, 0, 0}, 14);
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  in = dev.read(0.002);
  EXPECT_EQ(in.position, Eigen::Vector3d(0.04, 0, 0));
  EXPECT_EQ(dev.dropped(), 1);
  EXPECT_EQ(dev.lost(), 3);
  const auto ev = dev.take_events();
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].kind, "device_gap");
  EXPECT_EQ(ev[0].value, 3.0);
  EXPECT_EQ(dev.samples_received(), 2);
}

// Review 2026-12-07: a second bridge was mixed into the hand unsaid; a restarted bridge
// (counting from 1 again) or one datagram far ahead stopped the stream for good ("device lost");
// NaN, 1 km and short datagrams were dropped without a word. Now: the foreign sender is dropped
// and said once, malformed datagrams are counted in an event, and after a silence longer than
// the timeout the next stream starts afresh.
TEST(UdpDevice, ForeignSendersMalformedDatagramsAndRestartedBridges) {
  e::UdpDevice dev({0, 0.2});  // a loaded machine stays far inside the timeout
  Bridge a(dev.port()), b(dev.port());
  const auto settle = [] { std::this_thread::sleep_for(std::chrono::milliseconds(3)); };
  const auto kinds = [&] {
    std::string k;
    for (const auto& ev : dev.take_events()) k += ev.kind + "=" + std::to_string(ev.value) + " ";
    return k;
  };
  a.send({0.01, 0, 0}, 100);
  settle();
  EXPECT_EQ(dev.read(0.001).position.x(), 0.01);
  b.send({0.5, 0, 0}, 1);
  b.send({0.5, 0, 0}, 2);
  a.send({0.02, 0, 0}, 101);
  settle();
  EXPECT_EQ(dev.read(0.002).position.x(), 0.02);
  std::string ev = kinds();
  EXPECT_EQ(std::count(ev.begin(), ev.end(), 'f'), 1) << ev;  // "device_foreign" once
  EXPECT_NE(ev.find("device_foreign="), std::string::npos) << ev;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  a.send({nan, 0, 0}, 102);
  a.send({1e6, 0, 0}, 103);
  const std::uint8_t short_datagram[10] = {};
  ::sendto(a.fd, short_datagram, sizeof short_datagram, 0, reinterpret_cast<sockaddr*>(&a.to),
           sizeof a.to);
  settle();
  EXPECT_EQ(dev.read(0.003).position.x(), 0.02);
  EXPECT_NE(kinds().find("device_malformed=3"), std::string::npos);
  // A haptic loop delayed past the timeout, with an intruder's datagram queued before the
  // bridge's: the bridge, whose datagram is in the same batch, stays.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  b.send({0.7, 0, 0}, 10);
  a.send({0.025, 0, 0}, 104);
  EXPECT_EQ(dev.read(0.0031).position.x(), 0.025);
  EXPECT_EQ(kinds().find("device_sender_changed"), std::string::npos);
  // a stops; b, restarted, counts from 1: after the timeout its stream is taken.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  dev.read(0.3);  // device_timeout
  e::Rendered r;
  r.t = 0.3;
  r.force = {0, 0, 2.0};
  dev.write(r);  // force off: the session logs the zero the hand got
  EXPECT_TRUE(dev.force_withheld());
  b.send({0.03, 0, 0}, 1);
  settle();
  EXPECT_EQ(dev.read(0.301).position.x(), 0.03);
  dev.write(r);
  EXPECT_FALSE(dev.force_withheld());
  ev = kinds();
  EXPECT_NE(ev.find("device_sender_changed"), std::string::npos) << ev;
  EXPECT_NE(ev.find("device_timeout"), std::string::npos) << ev;
  EXPECT_NE(ev.find("device_resumed"), std::string::npos) << ev;
  // One datagram far ahead: the next ones look old until the stream falls silent, then resume.
  b.send({0.04, 0, 0}, 1u << 31);
  b.send({0.05, 0, 0}, 2);
  settle();
  EXPECT_EQ(dev.read(0.302).position.x(), 0.04);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  dev.read(0.6);
  b.send({0.06, 0, 0}, 3);
  settle();
  EXPECT_EQ(dev.read(0.601).position.x(), 0.06);
}

TEST(UdpDevice, EventsTakenFromAnotherThreadWhileTheHapticThreadReads) {
  // A real-time session's writer thread takes the device's events while the haptic thread reads
  // datagrams (protocols/runner.cpp). Every datagram here skips a sequence number, so every read
  // that drains one adds a device_gap event: no event may be lost or duplicated across the two
  // threads (the sum of the gaps taken equals lost()), and nothing may crash (ASan in CI).
  e::UdpDevice dev({0, 1.0});  // no timeout events while the test runs (300 ms)
  Bridge br(dev.port());
  std::atomic<bool> stop{false};
  std::thread haptic([&] {
    double t = 0;
    while (!stop.load()) {
      dev.read(t);
      t += 0.001;
    }
  });
  double gaps = 0;
  long taken = 0;
  const auto end = Clock::now() + std::chrono::milliseconds(300);
  for (std::uint32_t s = 1; Clock::now() < end; s += 2) {
    br.send({0.01, 0, 0}, s);
    for (const auto& ev : dev.take_events()) {
      EXPECT_EQ(ev.kind, "device_gap");
      gaps += ev.value;
      ++taken;
    }
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(20));  // the last datagrams drain
  stop = true;
  haptic.join();
  for (const auto& ev : dev.take_events()) {
    gaps += ev.value;
    ++taken;
  }
  EXPECT_GT(taken, 10);
  EXPECT_EQ(gaps, static_cast<double>(dev.lost()));
  EXPECT_EQ(dev.samples_received() - 1, taken);  // every datagram after the first had a gap
}

TEST(UdpDevice, PortInUseIsAnInputError) {
  e::UdpDevice a({0, 0.002});
  EXPECT_THROW(e::UdpDevice({a.port(), 0.002}), palplab::InputError);
}

// The haptic loop runs at 1 kHz (the real-time clock) on prototype A; the bridge sends at 1 kHz
// and then goes silent. Within 5 ms of its last position it must receive a force-off datagram
// (when neither thread was descheduled),
// and the device must report a device_timeout event.
TEST(UdpDevice, SilentBridgeGetsForceOffWithinFiveMs) {
  e::Scene scene = palplab::prototypes::build_scene(proto("A"));
  const auto& g = scene.geometry();
  const int node = e::press_node(g, "ovary_left");
  const Eigen::Vector3d inside = g.V.row(node).transpose() - 0.003 * g.N.row(node).transpose();
  e::UdpDevice dev({0, 0.002});
  Bridge br(dev.port());
  std::atomic<bool> done{false};
  double off_latency_ms = -1.0, last_force = 0.0;
  double bridge_gap_ms = 0.0;  // the longest the silent bridge itself went without polling
  long forces = 0;
  // Sends for 80 ms, then listens until the force off has come (bounded at 10 s: a loaded
  // machine may stall the haptic thread well past a fixed window); the haptic loop runs until
  // the bridge is done.
  std::thread bridge([&] {
    const auto t0 = Clock::now();
    auto next = t0;
    Clock::time_point last_send = t0, last_poll = t0;
    while (off_latency_ms < 0 && Clock::now() - t0 < std::chrono::seconds(10)) {
      const auto now = Clock::now();
      const bool sending = now - t0 < std::chrono::milliseconds(80);
      if (sending) {
        br.send(inside);
        last_send = Clock::now();
      } else if (off_latency_ms < 0) {
        bridge_gap_ms = std::max(
            bridge_gap_ms, std::chrono::duration<double, std::milli>(now - last_poll).count());
      }
      last_poll = now;
      while (auto f = br.receive()) {
        ++forces;
        if (sending && (f->flags & e::kUdpForceOff) == 0) last_force = f->f.norm();
        if (!sending && (f->flags & e::kUdpForceOff) && off_latency_ms < 0)
          off_latency_ms =
              std::chrono::duration<double, std::milli>(Clock::now() - last_send).count();
      }
      next += std::chrono::microseconds(1000);
      if (sending) {
        std::this_thread::sleep_until(next);
      } else {  // silent: poll finely so the measured latency is palplab's, not ours
        std::this_thread::sleep_for(std::chrono::microseconds(50));
      }
    }
    done = true;
  });
  e::RealtimeOptions ro;
  ro.duration = 20.0;
  ro.frame_period = 0.0;
  ro.stop = &done;
  std::vector<e::DeviceEvent> events;
  const e::RealtimeStats st = e::run_realtime(scene, dev, ro);
  bridge.join();
  for (auto& ev : dev.take_events()) events.push_back(ev);
  EXPECT_GT(forces, st.steps / 2) << st.steps << " haptic steps";  // one per step, once connected
  EXPECT_GT(last_force, 0.5);  // it was pressing 3 mm into the organ
  ASSERT_GE(off_latency_ms, 0.0) << "no force-off datagram after the bridge went silent";
  // The timeout counts from the step that read the last position (up to one haptic period after
  // it arrived) and the force off goes with the first step after it (up to one more): 2 ms + two
  // 1 ms steps + delivery < 5 ms. On a shared, overloaded machine (ASan in CI) either thread may
  // be descheduled: the haptic thread (each of those two periods grows to the longest haptic
  // period the clock measured) or the bridge thread that measures the latency (it sees the
  // datagram only when it next polls, so the bound grows by its longest gap between polls). Both
  // are measured, not guessed.
  const double worst_period_ms = st.period_max_us / 1e3;
  // With neither thread late (periods of 1 ms, no poll gap) the bound is the 5 ms.
  EXPECT_LE(off_latency_ms, 2.0 + 2.0 * std::max(worst_period_ms, 1.0) + 1.0 + bridge_gap_ms)
      << "haptic period max " << worst_period_ms << " ms, bridge poll gap max " << bridge_gap_ms
      << " ms";
  bool timeout = false;
  for (const auto& ev : events) timeout = timeout || ev.kind == "device_timeout";
  EXPECT_TRUE(timeout);
}

TEST(DeviceSelfTest, RefusesASlowDeviceAndAcceptsAFastOne) {
  e::UdpDevice dev({0, 0.002});
  Bridge br(dev.port());
  // Silent bridge: 0 Hz.
  try {
    e::require_device_rate(dev, "udp:" + std::to_string(dev.port()), 900.0, 0.1);
    FAIL() << "a silent device passed the self-test";
  } catch (const palplab::InputError& err) {
    const std::string m = err.what();
    EXPECT_NE(m.find("below the required 900 Hz"), std::string::npos) << m;
    EXPECT_NE(m.find("udp:"), std::string::npos) << m;
  }
  // A bridge at 1 kHz: the count follows the datagrams. Never more than were sent while the
  // rate was measured (what was queued before is not counted), at least half of them, and
  // >= 500 Hz when the bridge itself kept up (a loaded machine can delay the sending thread).
  std::atomic<bool> stop{false};
  std::atomic<long> sent{0};
  std::thread t([&] {
    auto next = Clock::now();
    for (int i = 0; i < 400 && !stop; ++i) {
      br.send({0, 0, 0});
      ++sent;
      next += std::chrono::microseconds(1000);
      std::this_thread::sleep_until(next);
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(20));  // a backlog before the window
  const long sent_before = sent;
  const e::DeviceRate r = e::require_device_rate(dev, "udp", 0.0, 0.2);
  const long sent_during = sent - sent_before;
  stop = true;
  t.join();
  EXPECT_TRUE(r.hardware);
  EXPECT_LE(r.samples, sent_during);
  EXPECT_GE(r.samples, sent_during / 2) << sent_during << " sent";
  if (sent_during / r.seconds > 900.0) {
    EXPECT_GT(r.rate_hz, 500.0);
  }
}

// Record a scripted press on prototype C (adaptive refinement, the hardest to reproduce) through
// the lock-step clock, write the trace, read it back, replay it: every sample and event equal.
TEST(TraceDevice, RecordAndReplayAreIdentical) {
  struct Log {
    std::vector<e::Sample> samples;
    std::vector<e::Event> events;
  };
  auto session = [](e::Device& dev) {
    e::Scene scene = palplab::prototypes::build_scene(proto("C1"));
    Log log;
    e::LockstepOptions lo;
    lo.duration = 2.0;
    lo.frame_period = 0.0;
    e::run_lockstep(scene, dev, lo, [&](const e::Rendered& r, const e::Sample& s) {
      log.samples.push_back(s);
      log.events.insert(log.events.end(), r.events.begin(), r.events.end());
    });
    return log;
  };
  e::Scene probe = palplab::prototypes::build_scene(proto("C1"));
  const int node = e::press_node(probe.geometry(), "ovary_left");
  e::PressDevice press(e::press_at(probe.geometry(), node, 2.0, 0.2, 0.1));
  e::TraceRecorder rec(press);
  const Log a = session(rec);
  ASSERT_GT(a.samples.size(), 100u);
  ASSERT_FALSE(a.events.empty());
  const auto path = std::filesystem::temp_directory_path() /
                    ("palplab_trace_" + std::to_string(getpid()) + ".csv");
  rec.trace().meta["prototype"] = "C1";
  e::write_trace(path.string(), rec.trace());
  e::Trace tr = e::read_trace(path.string());
  std::filesystem::remove(path);
  EXPECT_EQ(tr.meta["prototype"], "C1");
  ASSERT_EQ(tr.samples.size(), rec.trace().samples.size());
  e::TraceDevice replay(std::move(tr));
  const Log b = session(replay);
  ASSERT_EQ(b.samples.size(), a.samples.size());
  for (size_t k = 0; k < a.samples.size(); ++k) {
    ASSERT_EQ(b.samples[k].x, a.samples[k].x) << k;
    ASSERT_EQ(b.samples[k].F, a.samples[k].F) << k;  // bit-identical forces
    ASSERT_EQ(b.samples[k].contact_node, a.samples[k].contact_node) << k;
  }
  ASSERT_EQ(b.events.size(), a.events.size());
  for (size_t k = 0; k < a.events.size(); ++k) {
    EXPECT_EQ(b.events[k].kind, a.events[k].kind);
    EXPECT_EQ(b.events[k].t, a.events[k].t);
    EXPECT_EQ(b.events[k].value, a.events[k].value);
  }
}

TEST(TraceDevice, BadFilesAreLocated) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("palplab_badtrace_" + std::to_string(getpid()) + ".csv");
  auto write = [&](const std::string& text) {
    FILE* f = fopen(path.c_str(), "w");
    fputs(text.c_str(), f);
    fclose(f);
  };
  write("t,x,y,z\n");
  EXPECT_THROW(e::read_trace(path.string()), palplab::InputError);
  write("# palplab-trace/1\nt,x,y,z,vx,vy,vz,buttons\n0,1,2,3,0,0,0,0\n0.001,1,2,x,0,0,0,0\n");
  try {
    e::read_trace(path.string());
    FAIL();
  } catch (const palplab::InputError& err) {
    EXPECT_NE(std::string(err.what()).find(":4:"), std::string::npos) << err.what();
  }
  write("# palplab-trace/1\nt,x,y,z,vx,vy,vz,buttons\n0.002,1,2,3,0,0,0,0\n0.001,1,2,3,0,0,0,0\n");
  EXPECT_THROW(e::read_trace(path.string()), palplab::InputError);
  // A trace is replayed one sample per haptic step: a gap, a negative start and positions or
  // velocities no hand has were taken (review 2026-12-06, fourth). Each is refused at its line.
  const std::string head = "# palplab-trace/1\nt,x,y,z,vx,vy,vz,buttons\n0,0,0,0,0,0,0,0\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {head + "0.001,0,0,0,0,0,0,0\n0.011,0,0,0,0,0,0,0\n",
       ":5: t: expected one sample per haptic step, 1 ms as between the first two"},
      {head + "0.02,0,0,0,0,0,0,0\n", ":4: t: expected a step between samples of 0.01 to 10 ms"},
      {"# palplab-trace/1\nt,x,y,z,vx,vy,vz,buttons\n-1,0,0,0,0,0,0,0\n",
       ":3: t: expected the first sample's time in [0, 86400] s"},
      {head + "0.001,0,0,1e300,0,0,0,0\n",
       ":4: column 4: expected a position within 10 m of the device origin"},
      {head + "0.001,0,0,0,0,-2e3,0,0\n", ":4: column 6: expected a velocity within 1000 m/s"},
      // A field with text after its number is that field's error (it was "expected 8
      // comma-separated columns" on a line of 8: review 2026-12-06, eighth); too few and too
      // many columns are said as such.
      {head + "0.001abc,0,0,0,0,0,0,0\n", ":4: column 1: expected a finite number, got '0.001abc'"},
      {head + "0.001,0.01 x,0,0,0,0,0,0\n", ":4: column 2: expected a finite number, got '0.01 x'"},
      {head + "0.001,0,0,0,0,0,0,5abc\n", ":4: column 8: expected a finite number, got '5abc'"},
      {head + "0.001,,0,0,0,0,0,0\n", ":4: column 2: expected a finite number, got ''"},
      {head + "0.001,0,0,0,0,0,0\n",
       ":4: expected 8 comma-separated columns (t,x,y,z,vx,vy,vz,buttons), got 7"},
      {head + "0.001,0,0,0,0,0,0,0,1\n", ":4: unexpected text after the 8th column"},
      // Decimal numbers only (strtod reads hexadecimal: 0x1p-3 was taken as 0.125 m).
      {head + "0.001,0x1p-3,0,0,0,0,0,0\n", ":4: column 2: expected a finite number, got '0x1p-3'"},
      // A long field is shown cut after 40 characters, never inside one (the cut was at 40
      // bytes: the 40th byte of 39 ASCII and a "ß" left half a character in the message).
      {head + "0.001," + std::string(39, '1') + "\u00df\u00df,0,0,0,0,0,0\n",
       ":4: column 2: expected a finite number, got '" + std::string(39, '1') +
           "\u00df\u2026 (43 bytes)'"}};
  for (const auto& [text, expect] : cases) {
    write(text);
    try {
      e::read_trace(path.string());
      ADD_FAILURE() << "accepted: " << text;
    } catch (const palplab::InputError& err) {
      EXPECT_NE(std::string(err.what()).find(expect), std::string::npos) << err.what();
    }
  }
  // A metadata value with a newline (a database path may hold one) is written escaped: the file
  // stays a trace (it was cut into a comment and a bad header line; review 2026-12-06, eighth).
  {
    e::Trace tr;
    tr.meta["database"] = "/tmp/a\nb.db";
    tr.samples.push_back({0.0, {}});
    tr.samples.push_back({0.001, {}});
    e::write_trace(path.string(), tr);
    const e::Trace back = e::read_trace(path.string());
    EXPECT_EQ(back.meta.at("database"), "/tmp/a\\x0ab.db");
    EXPECT_EQ(back.samples.size(), 2u);
    EXPECT_EQ(e::read_trace_meta(path.string()).at("database"), "/tmp/a\\x0ab.db");
  }
  // Steps of 1 ms as written with %.17g (k * 0.001) are taken.
  std::string ok = "# palplab-trace/1\nt,x,y,z,vx,vy,vz,buttons\n";
  for (int k = 0; k < 5000; ++k) {
    char line[96];
    std::snprintf(line, sizeof line, "%.17g,0,0,0.05,0,0,0,0\n", k * 0.001);
    ok += line;
  }
  write(ok);
  EXPECT_EQ(e::read_trace(path.string()).samples.size(), 5000u);
  EXPECT_NEAR(e::read_trace(path.string()).step, 0.001, 1e-15);
  // A 2 kHz trace is read with its step (the scene it is replayed into compares it: run --human
  // and view refuse a step that is not the scene's).
  write(head + "0.0005,0,0,0,0,0,0,0\n0.001,0,0,0,0,0,0,0\n");
  EXPECT_NEAR(e::read_trace(path.string()).step, 0.0005, 1e-15);
  std::filesystem::remove(path);
}
