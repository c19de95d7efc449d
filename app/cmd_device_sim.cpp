// `palplab device-sim --port P [--script FILE.json] [--rate HZ] [--duration S] [--stop-after S]
//  [--buttons MASK] [--axis AX AY AZ] [--json]`: a scripted hand on the UDP device protocol
// (engine/haptics/devices/udp_device.hpp),
// for tests and for checking a study setup without hardware. It sends position datagrams to
// 127.0.0.1:P at HZ (default 1000) along the script's piecewise-linear waypoints, receives the
// force datagrams, and prints a summary: datagrams sent and received, the largest force, and —
// with --stop-after — how long after its last position palplab's first "force off" arrived.
//
// Script: {"waypoints": [[t, x, y, z], ...]} (s, m; increasing t); the hand holds the last
// waypoint. Without --script the hand rests at the origin. Optional, for a stylus with buttons
// and an orientation sensor (a needle scene: buttons bit 1 = the needle tool):
//   "buttons": [[t, mask], ...]      the button mask from t on (0 before the first entry);
//   "axis": [[t, ax, ay, az], ...]   the stylus axis (handle -> tip), linear between entries,
//                                    normalised, held before the first and after the last.
// --buttons MASK / --axis AX AY AZ send a constant mask / axis instead (not with the script's).
// With an axis the datagrams are type 3 (96 bytes, with the axis); else type 1 (72 bytes).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "app/command.hpp"
#include "common/input_error.hpp"
#include "common/json_check.hpp"
#include "engine/haptics/device.hpp"
#include "engine/haptics/devices/udp_device.hpp"

namespace {

using namespace palplab;

struct SimArgs {
  int port = 0;
  std::string script;
  double rate = 1000.0, duration = -1.0, stop_after = -1.0, linger = 0.1;
  bool json = false;
  bool start_on_force = false;  // hold the first waypoint until palplab's forces arrive
  double wait = 30.0;           // s, the most to wait for them
  long buttons = -1;            // constant button mask (-1 = none given)
  std::vector<double> axis;     // constant stylus axis (empty = none given)
};

// The script's (or the options') buttons and stylus axis as functions of the script time.
struct StylusScript {
  std::vector<std::pair<double, std::uint32_t>> buttons;  // (t from, mask), increasing t
  std::vector<std::pair<double, Eigen::Vector3d>> axis;   // (t, unit axis), increasing t
  std::uint32_t buttons_at(double t) const {
    std::uint32_t b = 0;
    for (const auto& [t0, m] : buttons)
      if (t >= t0) b = m;
    return b;
  }
  Eigen::Vector3d axis_at(double t) const {
    if (axis.empty()) return Eigen::Vector3d::Zero();
    if (t <= axis.front().first) return axis.front().second;
    for (std::size_t i = 1; i < axis.size(); ++i)
      if (t < axis[i].first) {
        const double s = (t - axis[i - 1].first) / (axis[i].first - axis[i - 1].first);
        const Eigen::Vector3d a = (1 - s) * axis[i - 1].second + s * axis[i].second;
        // Opposite neighbours would pass through 0 half way: hold the earlier one there.
        return a.norm() > 1e-9 ? Eigen::Vector3d(a.normalized()) : axis[i - 1].second;
      }
    return axis.back().second;
  }
};

Eigen::Vector3d unit_axis(double x, double y, double z, const std::string& where) {
  const Eigen::Vector3d a(x, y, z);
  if (!a.allFinite() || !(a.norm() > 1e-9))
    throw InputError(where + ": expected a finite, non-zero stylus axis");
  return a.normalized();
}

// The script through the one JSON reader and validator (common/json_check): syntax errors,
// numbers beyond a double (1e999: "internal error", exit 3, before), duplicate keys and every
// value out of range are located FILE:LINE:COL: $.path problems, all reported at once.
// Each entry of `key` is a row of `width` numbers: the time (s, |t| <= 86400) and `width` - 1
// values in [lo, hi] (`what` names the row, "[t, x, y, z] (s, m)"); `take` gets the valid rows.
void read_rows(json::Checker& c, const nlohmann::json& root, const char* key, bool required,
               std::size_t width, double lo, double hi, const char* what,
               const std::function<void(const std::string&, const std::vector<double>&)>& take) {
  const std::string P = std::string("$.") + key;
  const nlohmann::json* rows = c.member(root, "$", key, required, "a non-empty array");
  if (!rows) return;
  if (!rows->is_array() || rows->empty()) {
    c.err(P, std::string("expected a non-empty array of ") + what + ", got " +
                 (rows->is_array() ? std::string("an empty array") : json::kind_name(*rows)));
    return;
  }
  double last_t = 0.0;
  for (std::size_t i = 0; i < rows->size(); ++i) {
    const std::string R = P + "[" + std::to_string(i) + "]";
    const nlohmann::json& e = (*rows)[i];
    if (!e.is_array() || e.size() != width) {
      c.err(R, std::string("expected ") + what + ", got " +
                   (e.is_array() ? "an array of " + std::to_string(e.size())
                                 : std::string(json::kind_name(e))));
      continue;
    }
    std::vector<double> v(width);
    bool ok = true;
    for (std::size_t k = 0; k < width; ++k) {
      const std::string V = R + "[" + std::to_string(k) + "]";
      const double l = k == 0 ? -86400.0 : lo, h = k == 0 ? 86400.0 : hi;
      if (!e[k].is_number()) {
        c.err(V, std::string("expected a number, got ") + json::kind_name(e[k]));
        ok = false;
      } else if (v[k] = e[k].get<double>(); !(v[k] >= l && v[k] <= h)) {
        c.err(V, std::string("expected ") + (k == 0 ? "a time (s)" : "a value") + " in [" +
                     json::Checker::fmt(l) + ", " + json::Checker::fmt(h) + "] of " + what +
                     ", got " + json::Checker::fmt(v[k]));
        ok = false;
      }
    }
    if (!ok) continue;
    if (i > 0 && v[0] <= last_t)
      c.err(R + "[0]", "expected times that increase (the previous entry is at " +
                           json::Checker::fmt(last_t) + " s), got " + json::Checker::fmt(v[0]));
    last_t = v[0];
    take(R, v);
  }
}

std::vector<std::pair<double, Eigen::Vector3d>> read_script(const std::string& path,
                                                            StylusScript& stylus) {
  std::string text;
  std::vector<Problem> repeated;  // reported with the file's other problems
  const nlohmann::json root = json::parse_json_file(path, &text, &repeated);
  json::Checker c(path, text);
  c.add(repeated);
  std::vector<std::pair<double, Eigen::Vector3d>> w;
  if (c.expect_object(root, "$")) {
    c.keys(root, "$", {"waypoints", "buttons", "axis"});
    // Positions within 10 m of the device origin (as a study's start_position).
    read_rows(c, root, "waypoints", true, 4, -engine::kMaxDevicePosition,
              engine::kMaxDevicePosition, "[t, x, y, z] (s, m)",
              [&](const std::string&, const std::vector<double>& v) {
                w.emplace_back(v[0], Eigen::Vector3d(v[1], v[2], v[3]));
              });
    read_rows(c, root, "buttons", false, 2, 0.0, 4294967295.0,
              "[t, mask] (s, an integer 0..4294967295)",
              [&](const std::string& R, const std::vector<double>& v) {
                if (v[1] != std::floor(v[1]))
                  c.err(R + "[1]", "expected an integer button mask 0..4294967295, got " +
                                       json::Checker::fmt(v[1]));
                stylus.buttons.emplace_back(v[0], static_cast<std::uint32_t>(v[1]));
              });
    read_rows(c, root, "axis", false, 4, -1e6, 1e6, "[t, ax, ay, az] (s, a direction)",
              [&](const std::string& R, const std::vector<double>& v) {
                const Eigen::Vector3d a(v[1], v[2], v[3]);
                if (!(a.norm() > 1e-9))
                  c.err(R, "expected a non-zero stylus axis (handle to tip), got [" +
                               json::Checker::fmt(v[1]) + ", " + json::Checker::fmt(v[2]) + ", " +
                               json::Checker::fmt(v[3]) + "]");
                else
                  stylus.axis.emplace_back(v[0], a.normalized());
              });
  }
  c.throw_if_any();
  return w;
}

// The numeric flags are range-checked by their validators (app/command.hpp: NaN, inf and values
// out of range are exit 2 naming the flag); run_device_sim checks what depends on the script.
int run_device_sim(const SimArgs& a) {
  using Clock = std::chrono::steady_clock;
  std::vector<std::pair<double, Eigen::Vector3d>> path = {{0.0, Eigen::Vector3d::Zero()}};
  StylusScript stylus;
  if (!a.script.empty()) path = read_script(a.script, stylus);
  if (a.buttons >= 0) {
    if (!stylus.buttons.empty())
      throw InputError("--buttons: the script has its own \"buttons\" (give one of them)");
    stylus.buttons = {{-1e300, static_cast<std::uint32_t>(a.buttons)}};
  }
  if (!a.axis.empty()) {
    if (a.axis.size() != 3) throw InputError("--axis: expected three numbers AX AY AZ");
    if (!stylus.axis.empty())
      throw InputError("--axis: the script has its own \"axis\" (give one of them)");
    stylus.axis = {{0.0, unit_axis(a.axis[0], a.axis[1], a.axis[2], "--axis")}};
  }
  const bool with_axis = !stylus.axis.empty();
  // Without --duration the run lasts to the script's end + 0.1 s, which must be in (0, 3600] s.
  const double duration = a.duration >= 0 ? a.duration : path.back().first + 0.1;
  if (!(duration > 0.0) || duration > 3600.0)
    throw InputError(
        SourceLocation{a.script},
        "the script ends at " + app::shown_number(path.back().first) +
            " s: the run to its end + 0.1 s must last (0, 3600] s (or give --duration)");
  // --stop-after past the end of the run would never stop the sending: refused, not clamped.
  if (a.stop_after > duration)
    throw InputError(SourceLocation{"--stop-after"},
                     app::shown_number(a.stop_after) + " s is after the end of the run at " +
                         app::shown_number(duration) + " s (" +
                         (a.duration >= 0 ? "--duration)"
                                          : "the script's end + 0.1 s; give --duration to run "
                                            "longer)") +
                         ": expected at most that");
  const double stop = a.stop_after >= 0 ? a.stop_after : duration;
  engine::ScriptedDevice hand(path);

  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error("device-sim: socket failed");
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(a.port));
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  sockaddr_in self{};
  self.sin_family = AF_INET;
  self.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&self), sizeof self);

  // The force-off latency is timed by the kernel's arrival stamp of each datagram
  // (SO_TIMESTAMPNS, CLOCK_REALTIME), not by when this process gets round to reading it: a loaded
  // machine can leave the simulator's own polling several ms late, and that is not palplab's
  // latency. Without the stamp (never on Linux) the read time stands in.
  const int stamp_on = 1;
  const bool stamped =
      ::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &stamp_on, sizeof stamp_on) == 0;
  using Wall = std::chrono::system_clock;

  long sent = 0, received = 0, force_off = 0, bad = 0;
  double max_force = 0.0, first_off_ms = -1.0;
  std::uint32_t last_ack = 0, last_buttons = 0;
  long button_changes = 0;
  const auto t0 = Clock::now();
  Wall::time_point last_send = Wall::now();
  bool silent = false;  // the send phase is over: the next force off is the one timed
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / a.rate));
  auto next = t0;
  std::uint32_t seq = 0;
  Eigen::Vector3d prev = path.front().second;
  // Intervals between successive sends once the script runs (its own scheduling on a loaded
  // machine): how stale a position can be when palplab reads it, which a test's timing bound
  // must allow besides palplab's own loop.
  std::vector<double> send_gaps_ms;
  Clock::time_point prev_send{};
  auto receive = [&] {
    std::uint8_t buf[256];
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec))];
    while (true) {
      iovec iov{buf, sizeof buf};
      msghdr msg{};
      msg.msg_iov = &iov;
      msg.msg_iovlen = 1;
      msg.msg_control = control;
      msg.msg_controllen = sizeof control;
      const ssize_t n = ::recvmsg(fd, &msg, MSG_DONTWAIT);
      if (n < 0) break;
      Wall::time_point arrived = Wall::now();
      for (cmsghdr* c = CMSG_FIRSTHDR(&msg); stamped && c; c = CMSG_NXTHDR(&msg, c))
        if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
          timespec ts;
          std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
          arrived = Wall::time_point(std::chrono::duration_cast<Wall::duration>(
              std::chrono::seconds(ts.tv_sec) + std::chrono::nanoseconds(ts.tv_nsec)));
        }
      const auto f = engine::decode_force(buf, static_cast<size_t>(n));
      if (!f) {
        ++bad;
        continue;
      }
      ++received;
      last_ack = f->ack;
      max_force = std::max(max_force, f->f.norm());
      if (f->flags & engine::kUdpForceOff) {
        ++force_off;
        if (first_off_ms < 0 && silent && sent > 0 && arrived >= last_send)
          first_off_ms = std::chrono::duration<double, std::milli>(arrived - last_send).count();
      }
    }
  };
  // Send phase: bounded by `stop` seconds.
  // With --start-on-force the script's clock starts at the first force datagram (palplab's
  // session start: its device self-test reads without writing), so a scripted press lines up
  // with the session's time 0 to within a step and the delivery delay.
  bool started = !a.start_on_force;
  auto s0 = t0;
  while (true) {
    if (!started && received > 0) {
      started = true;
      s0 = Clock::now();
    }
    if (!started && Clock::now() - t0 > std::chrono::duration<double>(a.wait)) break;
    const double t = started ? std::chrono::duration<double>(Clock::now() - s0).count() : 0.0;
    if (t >= stop) break;
    const Eigen::Vector3d x = hand.read(t).position;
    engine::UdpPosition m;
    m.seq = ++seq;
    m.t_device = t;
    m.x = x;
    m.v = (x - prev) * a.rate;
    prev = x;
    m.buttons = stylus.buttons_at(t);
    if (m.buttons != last_buttons) ++button_changes;
    last_buttons = m.buttons;
    if (with_axis) {
      m.axis = stylus.axis_at(t);
      const auto b = engine::encode_with_axis(m);
      ::sendto(fd, b.data(), b.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to);
    } else {
      const auto b = engine::encode(m);
      ::sendto(fd, b.data(), b.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to);
    }
    last_send = Wall::now();
    const auto now = Clock::now();
    if (started && sent > 0 && prev_send > s0)
      send_gaps_ms.push_back(std::chrono::duration<double, std::milli>(now - prev_send).count());
    prev_send = now;
    ++sent;
    receive();
    next += period;
    std::this_thread::sleep_until(next);
  }
  // Silent phase: keep receiving (force-off latency), bounded by `linger`.
  silent = true;
  const auto end =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(
                         std::chrono::duration<double>(a.stop_after >= 0 ? a.linger : 0.02));
  while (Clock::now() < end) {
    receive();
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  ::close(fd);
  // p99 and largest send interval (ms; -1 with fewer than two sends after the start).
  double gap_p99 = -1.0, gap_max = -1.0;
  if (!send_gaps_ms.empty()) {
    std::sort(send_gaps_ms.begin(), send_gaps_ms.end());
    gap_max = send_gaps_ms.back();
    gap_p99 =
        send_gaps_ms[static_cast<size_t>(0.99 * static_cast<double>(send_gaps_ms.size() - 1))];
  }
  nlohmann::json out = {{"port", a.port},
                        {"sent", sent},
                        {"received", received},
                        {"force_off_datagrams", force_off},
                        {"malformed", bad},
                        {"max_force", max_force},
                        {"last_ack", last_ack},
                        {"stopped_at", stop},
                        {"datagram_type", with_axis ? 3 : 1},
                        {"button_changes", button_changes},
                        // null when no force off came (was -1, a time).
                        {"force_off_after_stop_ms",
                         first_off_ms >= 0 ? nlohmann::json(first_off_ms) : nlohmann::json()},
                        {"send_interval_p99_ms", gap_p99},
                        {"send_interval_max_ms", gap_max}};
  if (a.json) {
    std::cout << out.dump(2) << "\n";
  } else {
    std::cout << "device-sim: sent " << sent << " positions to 127.0.0.1:" << a.port
              << ", received " << received << " forces (max " << max_force << " N)";
    if (a.stop_after >= 0 && first_off_ms >= 0)
      std::cout << "; force off " << first_off_ms << " ms after the last position";
    else if (a.stop_after >= 0)
      std::cout << "; no force off came after the last position";
    std::cout << "\n";
  }
  return received > 0 ? 0 : 1;
}

palplab::app::CommandRegistration reg_device_sim{
    "device-sim", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand(
          "device-sim", "Play a scripted hand over the UDP device protocol (for tests)");
      auto a = std::make_shared<SimArgs>();
      using palplab::app::finite_range;
      // -1 (duration, stop_after) means "not given": the validators refuse every negative value.
      cmd->add_option("--port", a->port, "palplab's UDP port on 127.0.0.1")
          ->required()
          ->check(palplab::app::count_range(1, 65535));
      cmd->add_option("--script", a->script, "JSON {\"waypoints\": [[t, x, y, z], ...]} (s, m)");
      cmd->add_option("--rate", a->rate, "Position datagrams per second (default 1000)")
          ->check(finite_range(1, 10000));
      cmd->add_option("--duration", a->duration, "Seconds to run (default: script end + 0.1)")
          ->check(finite_range(0, 3600, true));
      auto* stop_opt =
          cmd->add_option("--stop-after", a->stop_after,
                          "Stop sending after S seconds and measure the force-off latency")
              ->check(finite_range(0, 3600, true));
      auto* linger_opt = cmd->add_option("--linger", a->linger,
                                         "Seconds to listen after --stop-after (default 0.1)")
                             ->check(finite_range(0, 10));
      cmd->add_flag("--json", a->json, "Print the summary as JSON");
      cmd->add_flag("--start-on-force", a->start_on_force,
                    "Hold the first waypoint until forces arrive, then start the script");
      auto* wait_opt =
          cmd->add_option("--wait", a->wait, "With --start-on-force: seconds to wait (default 30)")
              ->check(finite_range(0, 3600, true));
      cmd->add_option("--buttons", a->buttons,
                      "Constant button mask in every datagram (bit 1 = a needle scene's needle)")
          ->check(palplab::app::count_range(0, 4294967295));
      cmd->add_option("--axis", a->axis,
                      "Constant stylus axis AX AY AZ (handle -> tip; sends type-3 datagrams)")
          ->expected(3);
      cmd->callback([a, stop_opt, linger_opt, wait_opt, code] {
        palplab::app::flag_only_with(linger_opt, stop_opt->count() > 0, "--stop-after");
        palplab::app::flag_only_with(wait_opt, a->start_on_force, "--start-on-force");
        *code = run_device_sim(*a);
      });
    }};

}  // namespace
