// A person's needle session (issue 16, `run --human` on a needle study): the tool and the stylus
// axis come from the device (engine/haptics/devices/tool_switch.hpp). Driving prototype N through
// ToolSwitchDevice with the needle button and an axis in the samples renders exactly (==) what
// the virtual trainee's path renders with the same commands given to Scene::set_tool, events
// (tool_changed, tissue_entered, ...) included; the trace format and the UDP protocol carry the
// axis; a device without one keeps the prototype's axis.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "common/input_error.hpp"
#include "engine/haptics/devices/mouse_device.hpp"
#include "engine/haptics/devices/tool_switch.hpp"
#include "engine/haptics/devices/trace_device.hpp"
#include "engine/haptics/devices/udp_device.hpp"
#include "prototypes/factory.hpp"

namespace {

using Eigen::Vector3d;
namespace e = palplab::engine;

const std::string kN = std::string(PALPLAB_SOURCE_DIR) + "/prototypes/N.json";

// A slanted posterior insertion: finger on the skin for 50 steps, then the needle (button bit 1)
// along `axis` from outside the skin 60 mm deep, then the needle put down.
std::vector<e::DeviceInput> insertion(const Vector3d& axis, bool with_axis) {
  std::vector<e::DeviceInput> in;
  const Vector3d entry(-0.002, -0.075, 0.0);
  for (int i = 0; i < 50; ++i) {
    e::DeviceInput d;
    d.position = entry + Vector3d(0, 0.0001 * i, 0);  // pressing the skin with the finger
    in.push_back(d);
  }
  const Vector3d from = entry - 0.01 * axis;
  for (int i = 0; i <= 1400; ++i) {
    e::DeviceInput d;
    d.position = from + (0.07 * i / 1400.0) * axis;
    d.buttons = e::kNeedleToolButton;
    if (with_axis) d.stylus_axis = axis;
    in.push_back(d);
  }
  for (int i = 0; i < 20; ++i) {
    e::DeviceInput d;
    d.position = in.back().position;
    in.push_back(d);
  }
  return in;
}

class ListDevice : public e::Device {
 public:
  explicit ListDevice(std::vector<e::DeviceInput> in) : in_(std::move(in)) {}
  e::DeviceInput read(double) override { return in_[std::min(k_++, in_.size() - 1)]; }
  void write(const e::Rendered&) override {}
  bool finished() const override { return k_ >= in_.size(); }

 private:
  std::vector<e::DeviceInput> in_;
  size_t k_ = 0;
};

struct Log {
  std::vector<Vector3d> force;
  std::vector<e::Event> events;
};

void record(Log& log, const e::Rendered& r) {
  log.force.push_back(r.force);
  log.events.insert(log.events.end(), r.events.begin(), r.events.end());
}

int count(const Log& l, e::EventKind k) {
  int n = 0;
  for (const auto& ev : l.events) n += ev.kind == k;
  return n;
}

TEST(NeedleDevice, ToolSwitchFromTheDeviceEqualsTheVirtualPath) {
  const Vector3d axis = Vector3d(0.15, 1.0, 0.05).normalized();
  const std::vector<e::DeviceInput> in = insertion(axis, true);

  // The human path: the device's buttons and axis through ToolSwitchDevice.
  e::Scene a = palplab::prototypes::build_scene(kN);
  ASSERT_EQ(a.tool(), "finger");
  ListDevice dev(in);
  e::ToolSwitchDevice tools(dev, a);
  Log la;
  while (!tools.finished()) {
    const e::DeviceInput d = tools.read(a.time());
    record(la, a.step(d.position));
  }
  // The virtual path (protocols/needle_session.cpp): set_tool when the command changes.
  e::Scene b = palplab::prototypes::build_scene(kN);
  Log lb;
  std::string tool = "finger";
  Vector3d ax = b.config().needle.axis;
  for (const auto& d : in) {
    const std::string t = (d.buttons & e::kNeedleToolButton) ? "needle" : "finger";
    const Vector3d x = d.stylus_axis.norm() > 0 ? d.stylus_axis : ax;
    if (t != tool || x != ax) {
      b.set_tool(t, x);
      tool = t;
      ax = x;
    }
    record(lb, b.step(d.position));
  }
  ASSERT_EQ(la.force.size(), in.size());
  ASSERT_EQ(la.force.size(), lb.force.size());
  for (size_t i = 0; i < la.force.size(); ++i) ASSERT_TRUE(la.force[i] == lb.force[i]) << i;
  ASSERT_EQ(la.events.size(), lb.events.size());
  for (size_t i = 0; i < la.events.size(); ++i) {
    EXPECT_EQ(la.events[i].kind, lb.events[i].kind) << i;
    EXPECT_EQ(la.events[i].t, lb.events[i].t) << i;
    EXPECT_EQ(la.events[i].value, lb.events[i].value) << i;
  }
  // What the person did is in the log: finger -> needle -> finger, the layers from the skin.
  EXPECT_EQ(count(la, e::EventKind::tool_changed), 2);
  std::vector<double> entered;
  for (const auto& ev : la.events)
    if (ev.kind == e::EventKind::tissue_entered) entered.push_back(ev.value);
  ASSERT_GE(entered.size(), 3u);
  EXPECT_EQ(entered[0], 100);  // skin
  EXPECT_EQ(entered[1], 101);  // soft tissue
  EXPECT_EQ(count(la, e::EventKind::insertion_start), 1);
  EXPECT_EQ(a.tool(), "finger");
}

TEST(NeedleDevice, ADeviceWithoutAnAxisKeepsThePrototypesAxis) {
  const Vector3d y = Vector3d::UnitY();  // N's model.axis
  e::Scene a = palplab::prototypes::build_scene(kN);
  e::Scene b = palplab::prototypes::build_scene(kN);
  ListDevice without(insertion(y, false)), with(insertion(y, true));
  e::ToolSwitchDevice ta(without, a), tb(with, b);
  long steps = 0;
  while (!ta.finished()) {
    const Vector3d xa = ta.read(a.time()).position, xb = tb.read(b.time()).position;
    ASSERT_TRUE(a.step(xa).force == b.step(xb).force) << steps;
    ++steps;
  }
  EXPECT_GT(steps, 1000);
}

TEST(NeedleDevice, MouseDeviceCarriesTheLatchedToolAndTheViewAxis) {
  e::MouseDevice m(Vector3d(0, -0.1, 0));
  e::DeviceInput d = m.read(0.0);
  EXPECT_EQ(d.buttons & e::kNeedleToolButton, 0u);
  EXPECT_EQ(d.stylus_axis, Vector3d::Zero());
  const Vector3d view = Vector3d(0.2, 1.0, -0.1).normalized();
  m.set_tool(true, view);
  m.set_position(Vector3d(0, -0.08, 0), true);
  d = m.read(0.001);
  EXPECT_EQ(d.buttons, 1u | e::kNeedleToolButton);
  EXPECT_EQ(d.stylus_axis, view);
}

TEST(NeedleDevice, TraceAndUdpCarryTheStylusAxis) {
  e::Trace tr;
  for (const auto& d : insertion(Vector3d(0.6, 0.8, 0.0), true))
    tr.samples.push_back({0.001 * static_cast<double>(tr.samples.size()), d});
  const auto path = std::filesystem::temp_directory_path() /
                    ("palplab_axis_trace_" + std::to_string(getpid()) + ".csv");
  e::write_trace(path.string(), tr);
  const e::Trace back = e::read_trace(path.string());
  ASSERT_EQ(back.samples.size(), tr.samples.size());
  for (size_t i = 0; i < tr.samples.size(); ++i) {
    ASSERT_EQ(back.samples[i].in.stylus_axis, tr.samples[i].in.stylus_axis) << i;
    ASSERT_EQ(back.samples[i].in.buttons, tr.samples[i].in.buttons) << i;
  }
  // A non-unit axis is a located error.
  {
    FILE* f = fopen(path.c_str(), "w");
    fputs("# palplab-trace/1\nt,x,y,z,vx,vy,vz,buttons,ax,ay,az\n0,0,0,0,0,0,0,2,0,2,0\n", f);
    fclose(f);
  }
  try {
    e::read_trace(path.string());
    ADD_FAILURE() << "a non-unit axis must be refused";
  } catch (const palplab::InputError& err) {
    EXPECT_NE(std::string(err.what()).find(":3:"), std::string::npos) << err.what();
  }
  std::filesystem::remove(path);

  e::UdpPosition p;
  p.seq = 3;
  p.buttons = e::kNeedleToolButton;
  p.x = {0.01, -0.07, 0.0};
  p.axis = Vector3d(0.0, 0.6, 0.8);
  const auto b = e::encode_with_axis(p);
  ASSERT_EQ(b.size(), 96u);
  EXPECT_EQ(b[6], 3);  // type: position with axis
  const auto q = e::decode_position(b.data(), b.size());
  ASSERT_TRUE(q);
  EXPECT_EQ(q->axis, p.axis);
  EXPECT_EQ(q->x, p.x);
  EXPECT_EQ(q->buttons, p.buttons);
  EXPECT_EQ(e::decode_position(e::encode(p).data(), 72)->axis, Vector3d::Zero());
  p.axis = {0.0, 3.0, 0.0};  // not a unit vector
  const auto bad = e::encode_with_axis(p);
  EXPECT_FALSE(e::decode_position(bad.data(), bad.size()));
  EXPECT_FALSE(e::decode_position(b.data(), 95));
}

}  // namespace
