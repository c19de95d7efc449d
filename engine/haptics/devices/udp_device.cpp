#include "engine/haptics/devices/udp_device.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

#include "common/input_error.hpp"

namespace palplab::engine {

namespace {

// Explicit little-endian (de)serialisation, independent of the host's byte order.
void put_u16(std::uint8_t* p, std::uint16_t v) {
  p[0] = v & 0xff;
  p[1] = v >> 8;
}
void put_u32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = (v >> (8 * i)) & 0xff;
}
void put_f64(std::uint8_t* p, double d) {
  std::uint64_t v;
  std::memcpy(&v, &d, 8);
  for (int i = 0; i < 8; ++i) p[i] = (v >> (8 * i)) & 0xff;
}
std::uint16_t get_u16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | p[1] << 8);
}
std::uint32_t get_u32(const std::uint8_t* p) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(p[i]) << (8 * i);
  return v;
}
double get_f64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  double d;
  std::memcpy(&d, &v, 8);
  return d;
}
void put_header(std::uint8_t* p, std::uint16_t type) {
  put_u32(p, kUdpMagic);
  put_u16(p + 4, kUdpVersion);
  put_u16(p + 6, type);
}
bool header_ok(const std::uint8_t* p, size_t n, size_t size, std::uint16_t type) {
  return n == size && get_u32(p) == kUdpMagic && get_u16(p + 4) == kUdpVersion &&
         get_u16(p + 6) == type;
}

}  // namespace

std::array<std::uint8_t, kUdpPositionSize> encode(const UdpPosition& m) {
  std::array<std::uint8_t, kUdpPositionSize> b{};
  put_header(b.data(), 1);
  put_u32(&b[8], m.seq);
  put_u32(&b[12], m.buttons);
  put_f64(&b[16], m.t_device);
  for (int k = 0; k < 3; ++k) {
    put_f64(&b[24 + 8 * k], m.x[k]);
    put_f64(&b[48 + 8 * k], m.v[k]);
  }
  return b;
}

std::array<std::uint8_t, kUdpPositionAxisSize> encode_with_axis(const UdpPosition& m) {
  std::array<std::uint8_t, kUdpPositionAxisSize> b{};
  const auto head = encode(m);
  std::copy(head.begin(), head.end(), b.begin());
  put_u16(&b[6], 3);
  for (int k = 0; k < 3; ++k) put_f64(&b[72 + 8 * k], m.axis[k]);
  return b;
}

std::array<std::uint8_t, kUdpForceSize> encode(const UdpForce& m) {
  std::array<std::uint8_t, kUdpForceSize> b{};
  put_header(b.data(), 2);
  put_u32(&b[8], m.seq);
  put_u32(&b[12], m.ack);
  put_u32(&b[16], m.flags);
  put_f64(&b[24], m.t);
  for (int k = 0; k < 3; ++k) put_f64(&b[32 + 8 * k], m.f[k]);
  return b;
}

std::optional<UdpPosition> decode_position(const std::uint8_t* p, size_t n) {
  const bool with_axis = header_ok(p, n, kUdpPositionAxisSize, 3);
  if (!with_axis && !header_ok(p, n, kUdpPositionSize, 1)) return std::nullopt;
  UdpPosition m;
  if (with_axis) {
    for (int k = 0; k < 3; ++k) m.axis[k] = get_f64(p + 72 + 8 * k);
    const double len = m.axis.norm();
    if (!m.axis.allFinite() || (len != 0.0 && std::abs(len - 1.0) > 1e-6)) return std::nullopt;
  }
  m.seq = get_u32(p + 8);
  m.buttons = get_u32(p + 12);
  m.t_device = get_f64(p + 16);
  for (int k = 0; k < 3; ++k) {
    m.x[k] = get_f64(p + 24 + 8 * k);
    m.v[k] = get_f64(p + 48 + 8 * k);
  }
  if (!m.x.allFinite() || !m.v.allFinite() || !std::isfinite(m.t_device)) return std::nullopt;
  return m;
}

std::optional<UdpForce> decode_force(const std::uint8_t* p, size_t n) {
  if (!header_ok(p, n, kUdpForceSize, 2)) return std::nullopt;
  UdpForce m;
  m.seq = get_u32(p + 8);
  m.ack = get_u32(p + 12);
  m.flags = get_u32(p + 16);
  m.t = get_f64(p + 24);
  for (int k = 0; k < 3; ++k) m.f[k] = get_f64(p + 32 + 8 * k);
  return m;
}

UdpDevice::UdpDevice(const UdpDeviceOptions& opt) : opt_(opt) {
  if (opt.port < 0 || opt.port > 65535)
    throw InputError("udp device: port " + std::to_string(opt.port) + " outside 0..65535");
  if (!(opt.timeout > 0.0) || opt.timeout > 1.0)
    throw InputError("udp device: timeout must be in (0, 1] s");
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error(std::string("udp device: socket: ") + std::strerror(errno));
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(opt.port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);  // localhost only
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    const int e = errno;
    ::close(fd_);
    throw InputError("udp device: cannot bind 127.0.0.1:" + std::to_string(opt.port) + ": " +
                     std::strerror(e));
  }
  socklen_t len = sizeof a;
  ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
  port_ = ntohs(a.sin_port);
}

UdpDevice::~UdpDevice() {
  if (fd_ >= 0) ::close(fd_);
}

void UdpDevice::drain(double t) {
  std::uint8_t buf[256];
  // This step's datagrams first, so that the bridge's liveness is judged by what arrived, not
  // by when the haptic loop last ran (a loop delayed past the timeout let a queued intruder take
  // over a live bridge: review of the fixes, 2026-12-07).
  batch_.clear();
  bool bridge_sent = false;  // the current bridge has datagrams in this batch
  while (true) {
    sockaddr_in from{};
    socklen_t len = sizeof from;
    const ssize_t n =
        ::recvfrom(fd_, buf, sizeof buf, MSG_DONTWAIT, reinterpret_cast<sockaddr*>(&from), &len);
    if (n < 0) break;  // EAGAIN: nothing more
    if (from.sin_family != AF_INET || ntohl(from.sin_addr.s_addr) >> 24 != 127) {
      ++dropped_;
      continue;
    }
    auto m = decode_position(buf, static_cast<size_t>(n));
    // A position beyond kMaxDevicePosition (10 m; a trace holds no more) is as malformed as a
    // NaN: the scene would take it for no contact, and a recorded trace would not replay.
    if (m && m->x.cwiseAbs().maxCoeff() > kMaxDevicePosition) m.reset();
    if (!m) {
      ++dropped_;
      ++malformed_;
      continue;
    }
    bridge_sent = bridge_sent || (have_peer_ && std::memcmp(peer_.data(), &from, sizeof from) == 0);
    batch_.push_back({from, *m});
  }
  const auto now = std::chrono::steady_clock::now();
  const auto older = [&](std::chrono::steady_clock::time_point since) {
    return std::chrono::duration<double>(now - since).count() > opt_.timeout;
  };
  if (bridge_sent) last_bridge_rx_ = now;
  // The bridge is live while its datagrams (taken or not) keep coming within the timeout.
  bool bridge_live = have_peer_ && !older(last_bridge_rx_);
  for (const Received& q : batch_) {
    const UdpPosition& p = q.m;
    // One bridge at a time: positions from another sender (address and port) while the bridge
    // is live are dropped and said (at most once a second; two bridges were mixed into one
    // hand: review 2026-12-07). A sender that follows a silent bridge takes over (a restarted
    // bridge has a new port), and that is said too.
    const bool same_sender = have_peer_ && std::memcmp(peer_.data(), &q.from, sizeof q.from) == 0;
    if (!same_sender && bridge_live) {
      ++dropped_;
      if (foreign_said_t_ < 0 || t - foreign_said_t_ >= 1.0) {
        foreign_said_t_ = t;
        add_event(t, "device_foreign", static_cast<double>(ntohs(q.from.sin_port)));
      }
      continue;
    }
    // Sequence numbers increase; a datagram not newer than the newest is late or repeated
    // (wrap-around after 2^32 datagrams = 50 days at 1 kHz is handled by serial arithmetic).
    // A new sender's stream, or the bridge's after no position was taken for the timeout,
    // starts afresh: a restarted bridge counts from 1 again, and one datagram far ahead in seq
    // must not stop every later one (both ended the session as "device lost").
    const bool fresh_stream = !have_sample_ || !same_sender || older(last_rx_);
    if (!fresh_stream && static_cast<std::int32_t>(p.seq - last_.seq) <= 0) {
      ++dropped_;
      continue;
    }
    if (!fresh_stream && p.seq - last_.seq > 1) {
      const std::uint32_t gap = p.seq - last_.seq - 1;
      lost_ += gap;
      add_event(t, "device_gap", static_cast<double>(gap));
    }
    if (have_peer_ && !same_sender)
      add_event(t, "device_sender_changed", static_cast<double>(ntohs(q.from.sin_port)));
    last_ = p;
    have_sample_ = true;
    ++received_;
    last_rx_ = last_bridge_rx_ = std::chrono::steady_clock::now();
    std::memcpy(peer_.data(), &q.from, sizeof q.from);
    have_peer_ = bridge_live = true;
    if (timed_out_) {
      timed_out_ = false;
      add_event(t, "device_resumed", 0.0);
    }
  }
  // Malformed datagrams (a bad size, magic, version or type; a non-finite or absurd value) are
  // dropped and said, at most once a second with the count since the last time.
  if (malformed_ > malformed_said_ && (malformed_said_ == 0 || t - malformed_t_ >= 1.0)) {
    add_event(t, "device_malformed", static_cast<double>(malformed_ - malformed_said_));
    malformed_said_ = malformed_;
    malformed_t_ = t;
  }
}

DeviceInput UdpDevice::read(double t) {
  t_ = t;
  drain(t);
  if (have_sample_ && !timed_out_ &&
      std::chrono::duration<double>(std::chrono::steady_clock::now() - last_rx_).count() >
          opt_.timeout) {
    timed_out_ = true;
    add_event(t, "device_timeout", opt_.timeout);
  }
  DeviceInput in;
  in.position = last_.x;
  in.velocity = last_.v;
  in.buttons = last_.buttons;
  in.button = (last_.buttons & 1u) != 0;
  in.stylus_axis = last_.axis;
  return in;
}

void UdpDevice::write(const Rendered& r) {
  withheld_ = false;
  if (!have_peer_) return;
  // Check the timeout again right before sending: the step may have taken a while.
  if (!timed_out_ &&
      std::chrono::duration<double>(std::chrono::steady_clock::now() - last_rx_).count() >
          opt_.timeout) {
    timed_out_ = true;
    add_event(t_, "device_timeout", opt_.timeout);
  }
  UdpForce f;
  f.seq = ++tx_seq_;
  f.ack = last_.seq;
  f.t = r.t;
  f.flags = (r.contact ? kUdpContact : 0u) | (r.audio ? kUdpAudio : 0u);
  withheld_ = timed_out_;
  if (timed_out_) {
    f.flags |= kUdpForceOff;  // the hand may have moved anywhere: no force on stale positions
  } else {
    f.f = r.force;
  }
  const auto b = encode(f);
  ::sendto(fd_, b.data(), b.size(), MSG_DONTWAIT, reinterpret_cast<const sockaddr*>(peer_.data()),
           sizeof(sockaddr_in));
}

void UdpDevice::add_event(double t, const char* kind, double value) {
  std::lock_guard lock(events_mu_);
  events_.push_back({t, kind, value});
}

std::vector<DeviceEvent> UdpDevice::take_events() {
  std::vector<DeviceEvent> e;
  std::lock_guard lock(events_mu_);
  e.swap(events_);
  return e;
}

long UdpDevice::samples_received() const {
  return received_;
}

}  // namespace palplab::engine
