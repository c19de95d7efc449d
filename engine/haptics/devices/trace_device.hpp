#pragma once
// Device tracks: record what a device gave the simulator, step by step, and replay it.
//
// A trace is a text file (docs/DEVICES.md):
//   # palplab-trace/1
//   # prototype=<id> dt=<s>          (optional key=value comments, kept as metadata)
//   t,x,y,z,vx,vy,vz,buttons          (or t,x,y,z,vx,vy,vz,buttons,ax,ay,az: with the stylus
//   0.001,0.0123...,...                axis, a unit vector or 0,0,0 = none)
// one line per haptic step, numbers printed with 17 significant digits so a replay feeds the
// scene bit-identical positions. Replay is by step index (not by time lookup): step k of the
// replay gets line k, so a replay through the lock-step clock reproduces the recorded session
// exactly (the scene is deterministic), whatever clock recorded it.
#include <map>
#include <string>
#include <vector>

#include "engine/haptics/device.hpp"

namespace palplab::engine {

struct TraceSample {
  double t = 0.0;  // s, simulated time the device was read at
  DeviceInput in;
};

struct Trace {
  std::map<std::string, std::string> meta;  // from "# key=value" lines
  std::vector<TraceSample> samples;
  double step = 0.0;  // s between samples, as read (0: fewer than two); uniform, checked
};

// Throws palplab::InputError (FILE:LINE: what) on a bad file.
Trace read_trace(const std::string& path);
// The "# key=value" lines before the first sample of the trace at `path` (its metadata), read
// without the samples; empty when the file is no palplab trace or cannot be read.
std::map<std::string, std::string> read_trace_meta(const std::string& path);
void write_trace(const std::string& path, const Trace& trace);

// Passes another device through and records every read() (the device track of a session).
class TraceRecorder : public Device {
 public:
  explicit TraceRecorder(Device& inner) : inner_(inner) {}
  DeviceInput read(double t) override;
  void write(const Rendered& r) override { inner_.write(r); }
  bool finished() const override { return inner_.finished(); }
  std::vector<DeviceEvent> take_events() override { return inner_.take_events(); }
  long samples_received() const override { return inner_.samples_received(); }
  bool force_withheld() const override { return inner_.force_withheld(); }
  const Trace& trace() const { return trace_; }
  Trace& trace() { return trace_; }

 private:
  Device& inner_;
  Trace trace_;
};

// Replays a trace: read() number k returns sample k; finished() after the last one (reads past
// the end hold the last sample).
class TraceDevice : public Device {
 public:
  explicit TraceDevice(Trace trace);
  DeviceInput read(double t) override;
  void write(const Rendered& r) override {}
  bool finished() const override { return next_ >= trace_.samples.size(); }
  const Trace& trace() const { return trace_; }

 private:
  Trace trace_;
  size_t next_ = 0;
};

}  // namespace palplab::engine
