// `palplab view PROTOTYPE.json [--frames N --screenshot FILE] [--size WxH]`: palpate a prototype
// in a window with the mouse as the device.
//
//   left drag      moves the contact point over the (rest) surface under the cursor
//   wheel          presses in / backs out along the view direction (1 mm per notch)
//   right drag     presses in (drag down) / backs out (drag up), 0.1 mm per pixel
//   middle drag    orbits the camera; W wireframe, T transparency, R release, Esc quit
//
// --device udp:PORT or trace:FILE takes the contact point from a bridge or a recorded track
// instead (the mouse then only orbits); a UDP device must pass the start-up rate self-test.
// The scene is stepped at 1 kHz by the real-time clock (engine/haptics/clock.hpp) on its own
// threads; the window thread draws the newest published frame and never blocks the haptic loop.
// The ST cue (force >= the contact region's ST with the audio cue on) is shown as a flash of the
// window border and played as a tone where there is a sound card (app/palpation_ui.hpp).
// --mouse-script FILE feeds scripted mouse input instead of the window's (tests under Xvfb).

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <deque>
#include <filesystem>
#include <iostream>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "app/command.hpp"
#include "app/palpation_ui.hpp"
#include "app/scene_option.hpp"
#include "common/format.hpp"
#include "common/input_error.hpp"
#include "engine/haptics/clock.hpp"
#include "engine/haptics/devices/device_spec.hpp"
#include "engine/haptics/devices/monitored_device.hpp"
#include "engine/haptics/devices/mouse_device.hpp"
#include "engine/haptics/devices/self_test.hpp"
#include "engine/haptics/devices/trace_device.hpp"
#include "engine/haptics/devices/udp_device.hpp"
#include "engine/render/mouse_control.hpp"
#include "engine/render/mouse_script.hpp"
#include "prototypes/factory.hpp"

namespace {

using namespace palplab;

struct ViewArgs {
  std::string file, screenshot, size = "1280x800", device = "mouse", record_trace, mouse_script;
  long frames = 0;
  double min_rate = 900.0;
  bool overwrite = false;
  std::vector<std::string> scene;  // --scene FILE.psim | KEY (app/scene_option.hpp)
};

// The newest frame published by the real-time clock, handed to the window thread.
struct FrameSlot {
  std::mutex mu;
  engine::Frame frame;
  bool fresh = false;
  engine::RealtimeStats stats;  // of the last completed clock run
  bool have_stats = false;
};

int run_view(const ViewArgs& a) {
  int W = 1280, H = 800;
  if (std::sscanf(a.size.c_str(), "%dx%d", &W, &H) != 2 || W < 64 || H < 64 || W > 8192 || H > 8192)
    throw InputError("--size: \"" + a.size + "\": expected WIDTHxHEIGHT, 64..8192 px per side");
  if (a.frames < 0) throw InputError("--frames: expected a count >= 0");
  if (!a.screenshot.empty() && a.frames == 0)
    throw InputError("--screenshot needs --frames N (the frame to save)");
  const engine::DeviceSpec spec = engine::parse_device_spec(a.device);
  // The outputs are never an input, each other, nor a file of another kind without --overwrite
  // (both replaced a results database silently: review 2026-12-06, eighth).
  std::vector<app::CommandInput> inputs;
  if (!a.file.empty()) inputs.push_back({"the prototype file", a.file});
  for (const auto& sc : a.scene) inputs.push_back({"the --scene file", sc});
  if (!a.mouse_script.empty()) inputs.push_back({"the --mouse-script file", a.mouse_script});
  if (spec.kind == "trace") inputs.push_back({"the --device trace", spec.file});
  if (!a.screenshot.empty())
    app::require_replaceable_output(
        "--screenshot", a.screenshot, inputs,
        [](const std::string& p) { return app::file_starts_with(p, "\x89PNG\r\n\x1a\n"); },
        "PNG image", a.overwrite);
  if (!a.record_trace.empty()) {
    std::error_code e1, e2;
    namespace fs = std::filesystem;
    if (!a.screenshot.empty() && fs::weakly_canonical(fs::absolute(a.screenshot), e1) ==
                                     fs::weakly_canonical(fs::absolute(a.record_trace), e2))
      throw InputError(SourceLocation{"--record-trace"},
                       "\"" + a.record_trace +
                           "\" is the --screenshot file too; expected another file for the trace");
    app::require_replaceable_output(
        "--record-trace", a.record_trace, inputs,
        [](const std::string& p) { return app::file_starts_with(p, "# palplab-trace/"); },
        "palplab trace file", a.overwrite);
  }
  if (!a.mouse_script.empty() && spec.kind != "mouse")
    throw InputError("--mouse-script needs --device mouse (it scripts the window's mouse)");
  if (!(a.min_rate >= 0.0) || a.min_rate > 100000.0)
    throw InputError("--min-device-rate: expected a rate in [0, 100000] Hz");
  engine::Scene scene = prototypes::build_scene(app::scene_prototype(a.file, a.scene));
  std::optional<render::MouseScript> script;
  if (!a.mouse_script.empty()) script = render::MouseScript::load(a.mouse_script);
  const engine::SceneGeometry& g = scene.geometry();
  engine::MouseDevice mouse(render::MouseControl::start_position(g));
  engine::Device* inner = &mouse;
  std::unique_ptr<engine::UdpDevice> udp;
  std::unique_ptr<engine::TraceDevice> replay;
  if (spec.kind == "udp") {
    udp = std::make_unique<engine::UdpDevice>(engine::UdpDeviceOptions{spec.port, 0.002});
    inner = udp.get();
  } else if (spec.kind == "trace") {
    engine::Trace tr = engine::read_trace(spec.file);
    // One sample per haptic step of this scene (a trace of another step plays too fast or
    // slow).
    if (tr.samples.size() > 1 && std::abs(tr.step - scene.dt()) > 1e-3 * scene.dt())
      throw InputError(SourceLocation{"--device"},
                       "\"" + spec.text + "\": the trace has a sample every " +
                           format_g(tr.step * 1e3, 6) + " ms, the scene's haptic step is " +
                           format_g(scene.dt() * 1e3, 6) +
                           " ms (a trace is replayed one sample per step)");
    replay = std::make_unique<engine::TraceDevice>(std::move(tr));
    inner = replay.get();
  }
  if (inner->samples_received() >= 0) {  // a hardware device: is it fast enough?
    const engine::DeviceRate rate = engine::require_device_rate(*inner, spec.text, a.min_rate);
    std::cout << "device " << spec.text << ": " << std::lround(rate.rate_hz) << " Hz\n";
  }
  engine::TraceRecorder recorder(*inner);
  engine::MonitoredDevice monitor(a.record_trace.empty() ? *inner
                                                         : static_cast<engine::Device&>(recorder));
  std::atomic<bool> stop{false};

  std::unique_ptr<app::PalpationUi> ui;
  try {
    ui = std::make_unique<app::PalpationUi>(W, H, "palplab view - prototype " + scene.prototype(),
                                            std::move(script));
  } catch (const render::NoWindowError& e) {
    // No display is the user's environment, not an internal error (as `run --device mouse`).
    throw InputError(std::string("view needs a window: ") + e.what());
  }
  ui->set_scene(app::UiScene::of(scene));
  app::ToneSwitch cued(monitor, ui->tone());

  FrameSlot slot;
  std::thread haptic([&] {
    // The real-time clock runs in 0.5 s spans back to back (its stats refresh the panel), until
    // the window closes.
    engine::RealtimeOptions ro;
    ro.duration = 0.5;
    ro.frame_period = 1.0 / 60.0;
    ro.stop = &stop;
    while (!stop.load()) {
      const engine::RealtimeStats st =
          engine::run_realtime(scene, cued, ro, [&](const engine::Frame& f) {
            std::lock_guard<std::mutex> lock(slot.mu);
            slot.frame = f;
            slot.fresh = true;
          });
      std::lock_guard<std::mutex> lock(slot.mu);
      slot.stats = st;
      slot.have_stats = true;
    }
  });

  engine::Frame frame;
  app::UiStatus status;
  while (!ui->closed()) {
    ui->begin_frame();
    bool fresh = false;
    {
      std::lock_guard<std::mutex> lock(slot.mu);
      if (slot.fresh) {
        std::swap(frame, slot.frame);
        slot.fresh = false;
        fresh = true;
      }
      if (slot.have_stats) status.loop = slot.stats;
    }
    ui->draw_palpation(spec.kind == "mouse" ? &mouse : nullptr, &monitor, fresh ? &frame : nullptr,
                       status);
    const bool last = a.frames > 0 && ui->frames() + 1 >= a.frames;
    ui->end_frame(last ? a.screenshot : "");
    if (last) ui->request_close();
  }
  stop = true;
  mouse.stop();
  haptic.join();
  const render::ToneCue& tone = ui->tone();
  if (tone.available())
    std::cout << "ST tone: " << std::lround(1000.0 * tone.tone_frames() / render::ToneCue::kRate)
              << " ms on ALSA device \"" << tone.device() << "\"\n";
  else
    std::cout << "ST tone: none (" << tone.error() << "); the flash only\n";
  if (!a.record_trace.empty()) {
    recorder.trace().meta["prototype"] = scene.prototype();
    recorder.trace().meta["device"] = spec.text;
    recorder.trace().meta["dt"] = std::to_string(scene.dt());
    engine::write_trace(a.record_trace, recorder.trace());
    std::cout << "wrote " << a.record_trace << " (" << recorder.trace().samples.size()
              << " samples)\n";
  }
  return 0;
}

palplab::app::CommandRegistration reg_view{
    "view", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand(
          "view", "Palpate a prototype in a window with the mouse as the haptic device");
      auto a = std::make_shared<ViewArgs>();
      cmd->add_option("prototype", a->file, "Prototype JSON file (or --scene)");
      palplab::app::add_scene_option(cmd, a->scene, false);
      cmd->add_option("--frames", a->frames, "Close after N frames (0 = run until closed)")
          ->check(palplab::app::count_range(0, 1000000000));
      cmd->add_option("--screenshot", a->screenshot, "Save the last frame as PNG (with --frames)");
      cmd->add_option("--size", a->size, "Window size WIDTHxHEIGHT (default 1280x800)");
      cmd->add_option("--device", a->device,
                      "mouse (default), udp:PORT (a bridge on 127.0.0.1, docs/DEVICES.md) or "
                      "trace:FILE (replay a recorded device track)");
      cmd->add_option("--min-device-rate", a->min_rate,
                      "Refuse a hardware device slower than this (Hz, default 900)")
          ->check(palplab::app::finite_range(0, 100000));
      cmd->add_option("--record-trace", a->record_trace, "Write the device track to FILE");
      cmd->add_option("--mouse-script", a->mouse_script,
                      "Scripted mouse input instead of the window's (JSON, docs/DEVICES.md)");
      cmd->add_flag("--overwrite", a->overwrite,
                    "Replace an existing --screenshot or --record-trace file of another kind");
      cmd->callback([a, code] { *code = run_view(*a); });
    }};

}  // namespace
