#pragma once
// The UDP device: a bridge program (around any vendor SDK) sends the stylus position to palplab
// and gets the force back, as little-endian datagrams on localhost (docs/DEVICES.md).
//
//   position (bridge -> palplab), 72 bytes:
//     0 u32 magic 0x444C5050 ("PPLD")   4 u16 version 1   6 u16 type 1
//     8 u32 seq (+1 per datagram)        12 u32 buttons (bit mask)
//    16 f64 t_device (s, bridge clock)   24 f64 x, y, z (m, organ frame)   48 f64 vx, vy, vz (m/s)
//   position with the stylus axis (type 3, for a device that measures its orientation), 96 bytes:
//     bytes 0..71 as type 1 (type field 3), 72 f64 ax, ay, az (unit, handle -> tip, organ frame;
//     0,0,0 = none). A needle scene takes the insertion direction from it
//     (devices/tool_switch.hpp; buttons bit 1 = the needle tool).
//   force (palplab -> bridge, to the sender of the newest position), 64 bytes:
//     0 u32 magic   4 u16 version 1   6 u16 type 2
//     8 u32 seq (palplab's, +1 per datagram)   12 u32 ack (seq of the newest position used)
//    16 u32 flags: bit 0 contact, bit 1 audio cue (force >= ST), bit 2 force off (timeout)
//    20 u32 reserved (0)   24 f64 t (s, simulated)   32 f64 fx, fy, fz (N, force on the hand)
//    56 f64 reserved (0)
//
// palplab binds 127.0.0.1:PORT only and ignores datagrams from other addresses, with a bad
// magic/version/type/size or a non-finite or absurd (> 10 m) value (device_malformed, at most
// once a second with the count), from a second sender while the first is live (device_foreign,
// at most once a second), or with a sequence number not newer than the newest one (late or
// duplicated). The bridge is live while its datagrams keep arriving within the timeout; after
// that the next sender takes over (device_sender_changed) and a stream starts afresh (a
// restarted bridge counts from 1 again; one datagram far ahead in seq does not stop the rest).
// When no fresh position arrived for `timeout` (default 2 ms), every force datagram carries zero
// force and the "force off" flag until positions arrive again; events device_timeout /
// device_resumed / device_gap are reported through take_events().
#include <netinet/in.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "engine/haptics/device.hpp"

namespace palplab::engine {

constexpr std::uint32_t kUdpMagic = 0x444C5050u;  // "PPLD" little-endian
constexpr std::uint16_t kUdpVersion = 1;
constexpr size_t kUdpPositionSize = 72, kUdpPositionAxisSize = 96, kUdpForceSize = 64;

struct UdpPosition {
  std::uint32_t seq = 0, buttons = 0;
  double t_device = 0.0;
  Eigen::Vector3d x = Eigen::Vector3d::Zero(), v = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();  // stylus axis (type 3 only; 0 = none)
};
struct UdpForce {
  std::uint32_t seq = 0, ack = 0, flags = 0;
  double t = 0.0;
  Eigen::Vector3d f = Eigen::Vector3d::Zero();
};
enum UdpFlags : std::uint32_t { kUdpContact = 1u, kUdpAudio = 2u, kUdpForceOff = 4u };

std::array<std::uint8_t, kUdpPositionSize> encode(const UdpPosition& p);
std::array<std::uint8_t, kUdpForceSize> encode(const UdpForce& f);
// A type-3 position datagram (with m.axis).
std::array<std::uint8_t, kUdpPositionAxisSize> encode_with_axis(const UdpPosition& p);
// Empty when the bytes are not a well-formed datagram of that type.
std::optional<UdpPosition> decode_position(const std::uint8_t* data, size_t n);
std::optional<UdpForce> decode_force(const std::uint8_t* data, size_t n);

struct UdpDeviceOptions {
  int port = 0;            // 127.0.0.1:port; 0 = any free port (see port())
  double timeout = 0.002;  // s without a fresh position before the force is switched off
};

class UdpDevice : public Device {
 public:
  // Binds the socket; throws palplab::InputError when the port is taken or invalid.
  explicit UdpDevice(const UdpDeviceOptions& opt);
  ~UdpDevice() override;
  UdpDevice(const UdpDevice&) = delete;
  UdpDevice& operator=(const UdpDevice&) = delete;

  DeviceInput read(double t) override;
  void write(const Rendered& r) override;
  std::vector<DeviceEvent> take_events() override;
  long samples_received() const override;                     // fresh positions since construction
  bool force_withheld() const override { return withheld_; }  // the last write was force off

  int port() const { return port_; }
  bool timed_out() const { return timed_out_; }
  bool connected() const { return have_peer_; }
  long dropped() const { return dropped_; }  // stale, malformed or foreign datagrams ignored
  long lost() const { return lost_; }        // sequence numbers skipped

 private:
  void drain(double t);
  int fd_ = -1;
  int port_ = 0;
  UdpDeviceOptions opt_;
  bool have_peer_ = false, have_sample_ = false, timed_out_ = false;
  std::array<std::uint8_t, 16> peer_{};  // sockaddr_in of the bridge
  UdpPosition last_;
  std::chrono::steady_clock::time_point last_rx_;
  std::uint32_t tx_seq_ = 0;
  // received_ and events_ are read by the session's writer thread while the haptic thread
  // drains datagrams (Device::take_events): an atomic counter and a mutex. Unguarded, a device
  // gap under load pushed into events_ while the writer swapped it out (a crash seen once).
  std::atomic<long> received_{0};
  long dropped_ = 0, lost_ = 0;
  long malformed_ = 0, malformed_said_ = 0;  // malformed datagrams, and those said in events
  double malformed_t_ = 0.0;                 // when device_malformed was last logged
  double foreign_said_t_ = -1.0;             // when device_foreign was last logged
  struct Received {
    sockaddr_in from;
    UdpPosition m;
  };
  std::vector<Received> batch_;  // one step's well-formed positions (capacity kept)
  std::chrono::steady_clock::time_point last_bridge_rx_;  // any datagram of the bridge
  bool withheld_ = false;  // the last force datagram had the force-off flag
  double t_ = 0.0;
  std::mutex events_mu_;
  std::vector<DeviceEvent> events_;
  void add_event(double t, const char* kind, double value);
};

}  // namespace palplab::engine
