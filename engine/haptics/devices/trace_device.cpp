#include "engine/haptics/devices/trace_device.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include "common/input_error.hpp"
#include "common/remove_on_signal.hpp"

namespace palplab::engine {

namespace {
const char* kMagic = "# palplab-trace/1";
const char* kHeader = "t,x,y,z,vx,vy,vz,buttons";
// With the stylus axis (a device that reports one; a scripted needle insertion).
const char* kHeaderAxis = "t,x,y,z,vx,vy,vz,buttons,ax,ay,az";
}  // namespace

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
      const auto eq = line.find('=');
      if (eq != std::string::npos) {
        std::string key = line.substr(1, eq - 1);
        key.erase(0, key.find_first_not_of(' '));
        tr.meta[key] = line.substr(eq + 1);
      }
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
    for (int k = 0; k < cols; ++k) {
      char* end = nullptr;
      errno = 0;
      v[k] = std::strtod(p, &end);
      if (end == p || errno == ERANGE || !std::isfinite(v[k]))
        fail("column " + std::to_string(k + 1) + ": expected a finite number");
      p = end;
      if (k < cols - 1) {
        if (*p != ',')
          fail("expected " + std::to_string(cols) + " comma-separated columns (" + names + ")");
        ++p;
      } else if (*p != '\0') {
        fail("unexpected text after the " + std::to_string(cols) + "th column");
      }
    }
    if (v[7] < 0 || v[7] != std::floor(v[7]) || v[7] > 4294967295.0)
      fail("buttons: expected a non-negative whole number (bit mask)");
    if (!tr.samples.empty() && v[0] < tr.samples.back().t)
      fail("time goes backwards (" + std::to_string(v[0]) + " s after " +
           std::to_string(tr.samples.back().t) + " s)");
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
  // Written beside the target (PATH.partial) and renamed over it, so that a failed write (a full
  // disk) never leaves half a trace in place of the earlier one. A target that is a link or not a
  // regular file (/dev/stdout, a pipe) is written directly, as it was.
  namespace fs = std::filesystem;
  std::error_code ec;
  const auto st = fs::symlink_status(path, ec);
  const bool direct = fs::exists(st) && !fs::is_regular_file(st);
  const std::string tmp = direct ? path : path + ".partial";
  // Removed if the process is interrupted before the rename (not the target written directly).
  std::optional<RemoveOnSignal> partial;
  if (!direct) partial.emplace(tmp);
  std::FILE* f = std::fopen(tmp.c_str(), "w");
  if (!f)
    throw InputError(path + ": cannot write the trace: " + std::strerror(errno) +
                     (direct ? "" : " (writing " + tmp + ")"));
  std::fprintf(f, "%s\n", kMagic);
  for (const auto& [k, v] : trace.meta) std::fprintf(f, "# %s=%s\n", k.c_str(), v.c_str());
  // The axis columns only when the device reported an axis (older readers read the rest).
  bool axis = false;
  for (const auto& s : trace.samples) axis = axis || s.in.stylus_axis != Eigen::Vector3d::Zero();
  std::fprintf(f, "%s\n", axis ? kHeaderAxis : kHeader);
  for (const auto& s : trace.samples) {
    const auto& p = s.in.position;
    const auto& v = s.in.velocity;
    const unsigned b = s.in.buttons | (s.in.button ? 1u : 0u);
    std::fprintf(f, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%u", s.t, p.x(), p.y(), p.z(), v.x(),
                 v.y(), v.z(), b);
    const auto& a = s.in.stylus_axis;
    if (axis) std::fprintf(f, ",%.17g,%.17g,%.17g", a.x(), a.y(), a.z());
    std::fputc('\n', f);
  }
  errno = 0;
  bool ok = std::fflush(f) == 0 && !std::ferror(f);
  const int why = errno;
  ok = std::fclose(f) == 0 && ok;
  if (!ok) {
    if (!direct) fs::remove(tmp, ec);
    throw InputError(
        path + ": writing the trace failed (" + (why ? std::strerror(why) : "write error") + ")" +
        (direct || !fs::exists(path, ec) ? std::string() : "; the file there before is unchanged"));
  }
  if (!direct) {
    fs::rename(tmp, path, ec);
    if (ec) {
      std::error_code e2;
      fs::remove(tmp, e2);
      throw InputError(path + ": cannot write the trace: " + ec.message());
    }
  }
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
