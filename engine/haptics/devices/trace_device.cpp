#include "engine/haptics/devices/trace_device.hpp"

#include "common/escape.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include "common/format.hpp"
#include "common/input_error.hpp"
#include "common/write_file.hpp"

namespace palplab::engine {

namespace {
const char* kMagic = "# palplab-trace/1";
const char* kHeader = "t,x,y,z,vx,vy,vz,buttons";
// With the stylus axis (a device that reports one; a scripted needle insertion).
const char* kHeaderAxis = "t,x,y,z,vx,vy,vz,buttons,ax,ay,az";
}  // namespace

namespace {
// A "# key=value" comment line into `meta` (other comments are ignored).
void add_meta(const std::string& line, std::map<std::string, std::string>& meta) {
  const auto eq = line.find('=');
  if (eq == std::string::npos) return;
  std::string key = line.substr(1, eq - 1);
  key.erase(0, key.find_first_not_of(' '));
  meta[key] = line.substr(eq + 1);
}
}  // namespace

std::map<std::string, std::string> read_trace_meta(const std::string& path) {
  std::map<std::string, std::string> meta;
  std::ifstream in(path);
  std::string line;
  if (!std::getline(in, line) || line.rfind(kMagic, 0) != 0) return meta;
  while (std::getline(in, line) && !line.empty() && line[0] == '#') {
    if (line.back() == '\r') line.pop_back();
    add_meta(line, meta);
  }
  return meta;
}

Trace read_trace(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open the trace: " + std::strerror(errno));
  Trace tr;
  std::string line;
  int ln = 0;
  auto fail = [&](const std::string& what) {
    throw InputError(path + ":" + std::to_string(ln) + ": " + what);
  };
  bool magic = false, header = false;
  int cols = 8;
  while (std::getline(in, line)) {
    ++ln;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    if (line[0] == '#') {
      if (ln == 1) {
        if (line != kMagic) fail("expected \"" + std::string(kMagic) + "\" on the first line");
        magic = true;
        continue;
      }
      add_meta(line, tr.meta);
      continue;
    }
    if (!magic) fail("not a palplab trace (expected \"" + std::string(kMagic) + "\")");
    if (!header) {
      if (line == kHeaderAxis)
        cols = 11;
      else if (line != kHeader)
        fail("expected the header \"" + std::string(kHeader) + "\" or \"" +
             std::string(kHeaderAxis) + "\"");
      header = true;
      continue;
    }
    double v[11] = {};
    const char* p = line.c_str();
    const std::string names = cols == 8 ? kHeader : kHeaderAxis;
    // The columns first (a field with text after its number, "0.01abc", was "expected 8
    // comma-separated columns" on a line of 8: review 2026-12-06, eighth), then each a number.
    const auto commas = std::count(line.begin(), line.end(), ',');
    if (commas < cols - 1)
      fail("expected " + std::to_string(cols) + " comma-separated columns (" + names + "), got " +
           std::to_string(commas + 1));
    for (int k = 0; k < cols; ++k) {
      const char* field_end = std::strchr(p, ',');
      if (!field_end || k == cols - 1) field_end = p + std::strlen(p);
      const std::string field(p, field_end);
      char* end = nullptr;
      errno = 0;
      // Decimal numbers only: strtod also reads hexadecimal ("0x1p-3" was taken as 0.125 m).
      if (field.find_first_of("xX") != std::string::npos)
        end = const_cast<char*>(p);
      else
        v[k] = std::strtod(p, &end);
      while (end < field_end && (*end == ' ' || *end == '\t')) ++end;
      if (end == p || end != field_end || errno == ERANGE || !std::isfinite(v[k])) {
        if (k == cols - 1 && end != p && end < field_end && *end == ',')
          fail("unexpected text after the " + std::to_string(cols) + "th column");
        fail("column " + std::to_string(k + 1) + ": expected a finite number, got '" +
             shown_text(field, 40) + "'");
      }
      p = field_end;
      if (k < cols - 1) ++p;
    }
    if (v[7] < 0 || v[7] != std::floor(v[7]) || v[7] > 4294967295.0)
      fail("buttons: expected a non-negative whole number (bit mask)");
    if (!tr.samples.empty() && v[0] < tr.samples.back().t)
      fail("time goes backwards (" + std::to_string(v[0]) + " s after " +
           std::to_string(tr.samples.back().t) + " s)");
    // A trace is replayed one sample per haptic step: its t must say so (the step of the scene
    // it is replayed into is compared by the caller with `step`). A 2 kHz trace played at half
    // speed, a gap of 10 ms was replayed as if nothing were missing and a first t of -1 s or a
    // position of 1e300 m was taken (review 2026-12-06, fourth).
    if (tr.samples.empty() && !(v[0] >= 0.0 && v[0] <= 86400.0))
      fail("t: expected the first sample's time in [0, 86400] s, got " + std::to_string(v[0]));
    if (tr.samples.size() == 1) {
      tr.step = v[0] - tr.samples.back().t;
      if (!(tr.step >= 1e-5 && tr.step <= 0.01))
        fail("t: expected a step between samples of 0.01 to 10 ms (a haptic step), got " +
             format_g(tr.step * 1e3, 6) + " ms");
    } else if (tr.samples.size() > 1 &&
               std::abs(v[0] - tr.samples.back().t - tr.step) > 1e-3 * tr.step) {
      fail("t: expected one sample per haptic step, " + format_g(tr.step * 1e3, 6) +
           " ms as between the first two (± 0.1 %: a trace is replayed step by step), got a step "
           "of " +
           format_g((v[0] - tr.samples.back().t) * 1e3, 6) +
           " ms (a gap, or a device sampled at another rate: resample it)");
    }
    for (int k = 1; k <= 3; ++k)
      if (std::abs(v[k]) > kMaxDevicePosition)
        fail("column " + std::to_string(k + 1) + ": expected a position within " +
             format_g(kMaxDevicePosition, 6) + " m of the device origin, got " +
             std::to_string(v[k]) + " m");
    for (int k = 4; k <= 6; ++k)
      if (std::abs(v[k]) > 1e3)
        fail("column " + std::to_string(k + 1) + ": expected a velocity within 1000 m/s, got " +
             std::to_string(v[k]) + " m/s");
    TraceSample s;
    s.t = v[0];
    s.in.position = {v[1], v[2], v[3]};
    s.in.velocity = {v[4], v[5], v[6]};
    s.in.buttons = static_cast<unsigned>(v[7]);
    s.in.button = (s.in.buttons & 1u) != 0;
    s.in.stylus_axis = {v[8], v[9], v[10]};
    if (cols == 11 && s.in.stylus_axis.norm() > 0 && std::abs(s.in.stylus_axis.norm() - 1.0) > 1e-6)
      fail("stylus axis (ax, ay, az): expected a unit vector or 0,0,0 (none), length " +
           std::to_string(s.in.stylus_axis.norm()));
    tr.samples.push_back(s);
  }
  if (!header)
    throw InputError(path + ": empty trace (no header \"" + std::string(kHeader) + "\")");
  return tr;
}

void write_trace(const std::string& path, const Trace& trace) {
  // Composed in memory and written by write_file: whole or not at all (a full disk or an
  // interruption leaves the earlier trace as it was); a link is written through, a device or a
  // pipe (/dev/stdout) directly.
  std::string text;
  text.reserve(64 + trace.samples.size() * 160);
  char buf[512];
  auto add = [&](int n) {
    // The longest line is 11 numbers of at most 24 characters; snprintf cannot truncate here.
    text.append(buf, static_cast<size_t>(std::max(n, 0)));
  };
  text += kMagic;
  text += '\n';
  // A value with a newline (a database path may hold one) would end its comment line and break
  // the file: control characters are written escaped (\x0a).
  for (const auto& [k, v] : trace.meta)
    text += "# " + escape_controls(k, false) + "=" + escape_controls(v, false) + "\n";
  // The axis columns only when the device reported an axis (older readers read the rest).
  bool axis = false;
  for (const auto& s : trace.samples) axis = axis || s.in.stylus_axis != Eigen::Vector3d::Zero();
  text += axis ? kHeaderAxis : kHeader;
  text += '\n';
  for (const auto& s : trace.samples) {
    const auto& p = s.in.position;
    const auto& v = s.in.velocity;
    const unsigned b = s.in.buttons | (s.in.button ? 1u : 0u);
    add(std::snprintf(buf, sizeof buf, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%u", s.t, p.x(),
                      p.y(), p.z(), v.x(), v.y(), v.z(), b));
    const auto& a = s.in.stylus_axis;
    if (axis) add(std::snprintf(buf, sizeof buf, ",%.17g,%.17g,%.17g", a.x(), a.y(), a.z()));
    text += '\n';
  }
  write_file(path, text, "the trace");
}

DeviceInput TraceRecorder::read(double t) {
  DeviceInput in = inner_.read(t);
  trace_.samples.push_back({t, in});
  return in;
}

TraceDevice::TraceDevice(Trace trace) : trace_(std::move(trace)) {}

DeviceInput TraceDevice::read(double /*t*/) {
  if (trace_.samples.empty()) return {};
  const size_t k = std::min(next_, trace_.samples.size() - 1);
  if (next_ < trace_.samples.size()) ++next_;
  return trace_.samples[k].in;
}

}  // namespace palplab::engine
