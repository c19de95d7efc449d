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
// window border and the force bar; no tone is played (no audio library among the dependencies).
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <deque>
#include <iostream>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "app/command.hpp"
#include "app/scene_option.hpp"
#include "common/input_error.hpp"
#include "engine/haptics/clock.hpp"
#include "engine/haptics/devices/device_spec.hpp"
#include "engine/haptics/devices/monitored_device.hpp"
#include "engine/haptics/devices/mouse_device.hpp"
#include "engine/haptics/devices/self_test.hpp"
#include "engine/haptics/devices/trace_device.hpp"
#include "engine/haptics/devices/udp_device.hpp"
#include "engine/render/pick.hpp"
#include "engine/render/renderer.hpp"
#include "engine/render/window.hpp"
#include "prototypes/factory.hpp"

namespace {

using namespace palplab;

struct ViewArgs {
  std::string file, screenshot, size = "1280x800", device = "mouse", record_trace;
  long frames = 0;
  double min_rate = 900.0;
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

void draw_panel(const engine::Scene& scene, const engine::RenderedSummary& s,
                const std::vector<engine::Thresholds>& th, const FrameSlot& slot_copy_stats,
                bool have_stats, double frame_ms_median, double frame_ms_max, double depth,
                bool& wireframe, bool& transparent) {
  const auto& g = scene.geometry();
  ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_Always);
  ImGui::SetNextWindowSize(ImVec2(380, 0), ImGuiCond_Always);
  ImGui::Begin("palplab", nullptr,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  ImGui::Text("prototype %s", scene.prototype().c_str());
  const int r = s.contact_region;
  const std::string region =
      r >= 0 && r < static_cast<int>(g.region_names.size()) ? g.region_names[r] : "-";
  ImGui::Text("contact: %s   region: %s", s.contact ? "yes" : "no", region.c_str());
  const engine::Thresholds t = r >= 0 && r < static_cast<int>(th.size())
                                   ? th[r]
                                   : (th.empty() ? engine::Thresholds{} : th[0]);
  const double f = s.force.norm();
  ImGui::Text("force %.2f N (peak %.2f N)   depth %.1f mm", f, s.peak_force, depth * 1e3);
  // Force bar against ST / MPF / SFT of the contact region: full scale 1.25 x SFT.
  const float full = static_cast<float>(std::max(1.25 * t.sft, 1e-3));
  const ImVec2 p0 = ImGui::GetCursorScreenPos();
  const float w = 300.0f, h = 22.0f;
  ImDrawList* dl = ImGui::GetWindowDrawList();
  dl->AddRectFilled(p0, ImVec2(p0.x + w, p0.y + h), IM_COL32(40, 40, 40, 255));
  const float fx = std::min(1.0f, static_cast<float>(f) / full) * w;
  const ImU32 col = f >= t.sft   ? IM_COL32(220, 30, 30, 255)
                    : f >= t.mpf ? IM_COL32(240, 140, 20, 255)
                    : f >= t.st  ? IM_COL32(240, 220, 40, 255)
                                 : IM_COL32(60, 180, 90, 255);
  dl->AddRectFilled(p0, ImVec2(p0.x + fx, p0.y + h), col);
  const struct {
    double v;
    const char* name;
  } marks[] = {{t.st, "ST"}, {t.mpf, "MPF"}, {t.sft, "SFT"}};
  for (const auto& m : marks) {
    const float x = p0.x + static_cast<float>(m.v) / full * w;
    dl->AddLine(ImVec2(x, p0.y - 2), ImVec2(x, p0.y + h + 2), IM_COL32(255, 255, 255, 255), 2.0f);
    dl->AddText(ImVec2(x - 8, p0.y + h + 2), IM_COL32(255, 255, 255, 255), m.name);
  }
  ImGui::Dummy(ImVec2(w, h + 18));
  ImGui::Text("ST %.2f  MPF %.2f  SFT %.2f N", t.st, t.mpf, t.sft);
  ImGui::Separator();
  ImGui::Text("frame %.1f ms median, %.1f ms max", frame_ms_median, frame_ms_max);
  if (have_stats) {
    const auto& st = slot_copy_stats.stats;
    ImGui::Text("haptic loop %.0f Hz: period %.0f us median,",
                1e6 / std::max(st.period_median_us, 1.0), st.period_median_us);
    ImGui::Text("  %.0f us p99, step %.0f us median, %ld overruns", st.period_p99_us,
                st.step_median_us, st.overruns);
  } else {
    ImGui::Text("haptic loop: measuring ...");
  }
  ImGui::Separator();
  ImGui::Checkbox("wireframe (W)", &wireframe);
  ImGui::SameLine();
  ImGui::Checkbox("transparent (T)", &transparent);
  ImGui::TextDisabled("L-drag move, wheel/R-drag press, M-drag orbit");
  ImGui::End();
}

int run_view(const ViewArgs& a) {
  int W = 1280, H = 800;
  if (std::sscanf(a.size.c_str(), "%dx%d", &W, &H) != 2 || W < 64 || H < 64 || W > 8192 || H > 8192)
    throw InputError("--size: \"" + a.size + "\": expected WIDTHxHEIGHT, 64..8192 px per side");
  if (a.frames < 0) throw InputError("--frames: expected a count >= 0");
  if (!a.screenshot.empty() && a.frames == 0)
    throw InputError("--screenshot needs --frames N (the frame to save)");
  const engine::DeviceSpec spec = engine::parse_device_spec(a.device);
  if (!(a.min_rate >= 0.0) || a.min_rate > 100000.0)
    throw InputError("--min-device-rate: expected a rate in [0, 100000] Hz");
  engine::Scene scene = prototypes::build_scene(app::scene_prototype(a.file, a.scene));
  const engine::SceneGeometry& g = scene.geometry();
  std::vector<engine::Thresholds> th;
  for (int r = 0; r < static_cast<int>(g.region_names.size()); ++r)
    th.push_back(scene.thresholds(r));
  const long coarse_nodes = scene.stats().coarse_nodes;

  // Start 2 mm outside the surface point nearest to the scene's start position.
  const int n0 = g.nearest_node(g.start_position);
  Eigen::Vector3d hit = g.V.row(n0).transpose();
  Eigen::Vector3d ray_dir = -g.N.row(n0).transpose();
  double depth = -0.002;  // m along the ray past the surface point (negative = outside)
  engine::MouseDevice mouse(hit + depth * ray_dir);
  engine::Device* inner = &mouse;
  std::unique_ptr<engine::UdpDevice> udp;
  std::unique_ptr<engine::TraceDevice> replay;
  if (spec.kind == "udp") {
    udp = std::make_unique<engine::UdpDevice>(engine::UdpDeviceOptions{spec.port, 0.002});
    inner = udp.get();
  } else if (spec.kind == "trace") {
    replay = std::make_unique<engine::TraceDevice>(engine::read_trace(spec.file));
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

  std::unique_ptr<render::Window> win;
  try {
    win = std::make_unique<render::Window>(W, H, "palplab view - prototype " + scene.prototype());
  } catch (const render::NoWindowError& e) {
    std::cerr << "palplab view: " << e.what() << "\n";
    return 3;
  }
  render::Renderer renderer(g);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini next to the user's files
  ImGui_ImplGlfw_InitForOpenGL(win->handle(), true);
  ImGui_ImplOpenGL3_Init("#version 330 core");

  FrameSlot slot;
  std::thread haptic([&] {
    // The real-time clock runs in 0.5 s spans back to back (its stats refresh the panel), until
    // the window closes.
    engine::RealtimeOptions ro;
    ro.duration = 0.5;
    ro.frame_period = 1.0 / 60.0;
    while (!stop.load()) {
      const engine::RealtimeStats st =
          engine::run_realtime(scene, monitor, ro, [&](const engine::Frame& f) {
            std::lock_guard<std::mutex> lock(slot.mu);
            slot.frame = f;
            slot.fresh = true;
          });
      std::lock_guard<std::mutex> lock(slot.mu);
      slot.stats = st;
      slot.have_stats = true;
    }
  });

  render::Camera cam;
  bool wireframe = false, transparent = false;
  double last_x = 0, last_y = 0;
  bool have_last = false;
  std::deque<double> frame_ms;
  auto t_prev = std::chrono::steady_clock::now();
  long frame_no = 0;
  int rc = 0;
  engine::Frame frame;
  FrameSlot stats_copy;
  while (!win->should_close()) {
    const render::WindowInput in = win->poll();
    const int fw = win->width(), fh = win->height();
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    const bool ui_mouse = ImGui::GetIO().WantCaptureMouse;
    for (int k = 0; k < in.n_keys; ++k) {
      if (in.keys_pressed[k] == GLFW_KEY_W) wireframe = !wireframe;
      if (in.keys_pressed[k] == GLFW_KEY_T) transparent = !transparent;
      if (in.keys_pressed[k] == GLFW_KEY_R) depth = -0.002;
      if (in.keys_pressed[k] == GLFW_KEY_ESCAPE) win->request_close();
    }
    const render::CameraMatrices m = renderer.matrices(cam, fw, fh);
    const double dx = have_last ? in.mouse_x - last_x : 0.0,
                 dy = have_last ? in.mouse_y - last_y : 0.0;
    if (!ui_mouse) {
      if (in.left) {
        Eigen::Vector3d o, d;
        m.unproject(in.mouse_x, in.mouse_y, o, d);
        if (auto h = render::pick_surface(g, o, d)) {
          hit = h->point;
          ray_dir = d;
        }
      }
      if (in.right) depth += dy * 1e-4;
      if (in.middle) {
        cam.azimuth_deg -= dx * 0.3;
        cam.elevation_deg = std::clamp(cam.elevation_deg + dy * 0.3, -89.0, 89.0);
      }
      depth += in.scroll * 1e-3;
    }
    depth = std::clamp(depth, -0.01, 0.05);
    last_x = in.mouse_x;
    last_y = in.mouse_y;
    have_last = true;
    mouse.set_position(hit + depth * ray_dir, in.left);
    const Eigen::Vector3d hcp = monitor.last_position();  // what the haptic loop used

    {
      std::lock_guard<std::mutex> lock(slot.mu);
      if (slot.fresh) {
        std::swap(frame, slot.frame);
        slot.fresh = false;
      }
      stats_copy.stats = slot.stats;
      stats_copy.have_stats = slot.have_stats;
    }
    if (frame.V.rows() > 0) renderer.update_surface(frame.V, frame.F, coarse_nodes);
    const engine::RenderedSummary s = monitor.last_rendered();
    render::DrawOptions opt;
    opt.wireframe = wireframe;
    if (transparent) opt.region_alpha.assign(g.region_names.size(), 0.45f);
    opt.device_position = hcp;
    opt.contact = s.contact;
    renderer.draw(cam, fw, fh, opt);
    if (s.audio) {  // the ST cue: a yellow border flash while the force is at or above ST
      const double b = 12.0;
      const std::array<float, 4> c = {1.0f, 0.85f, 0.1f, 0.85f};
      renderer.overlay_rect(fw, fh, 0, 0, fw, b, c);
      renderer.overlay_rect(fw, fh, 0, fh - b, fw, fh, c);
      renderer.overlay_rect(fw, fh, 0, 0, b, fh, c);
      renderer.overlay_rect(fw, fh, fw - b, 0, fw, fh, c);
    }
    std::vector<double> sorted(frame_ms.begin(), frame_ms.end());
    std::sort(sorted.begin(), sorted.end());
    draw_panel(scene, s, th, stats_copy, stats_copy.have_stats,
               sorted.empty() ? 0.0 : sorted[sorted.size() / 2],
               sorted.empty() ? 0.0 : sorted.back(), depth, wireframe, transparent);
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    ++frame_no;
    if (a.frames > 0 && frame_no >= a.frames) {
      if (!a.screenshot.empty()) {
        render::write_png(a.screenshot, win->read_back_buffer());
        std::cout << "wrote " << a.screenshot << " (frame " << frame_no << ", " << fw << "x" << fh
                  << ")\n";
      }
      win->request_close();
    }
    win->swap();
    // At most 60 frames/s even where swap does not wait for a vertical blank (Xvfb, some
    // drivers): the frames of a busy window would take the CPU from the haptic thread.
    std::this_thread::sleep_until(t_prev + std::chrono::microseconds(16667));
    const auto t_now = std::chrono::steady_clock::now();
    frame_ms.push_back(std::chrono::duration<double, std::milli>(t_now - t_prev).count());
    if (frame_ms.size() > 120) frame_ms.pop_front();
    t_prev = t_now;
  }
  stop = true;
  mouse.stop();
  haptic.join();
  if (!a.record_trace.empty()) {
    recorder.trace().meta["prototype"] = scene.prototype();
    recorder.trace().meta["device"] = spec.text;
    recorder.trace().meta["dt"] = std::to_string(scene.dt());
    engine::write_trace(a.record_trace, recorder.trace());
    std::cout << "wrote " << a.record_trace << " (" << recorder.trace().samples.size()
              << " samples)\n";
  }
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  return rc;
}

palplab::app::CommandRegistration reg{
    "view", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand(
          "view", "Palpate a prototype in a window with the mouse as the haptic device");
      auto a = std::make_shared<ViewArgs>();
      cmd->add_option("prototype", a->file, "Prototype JSON file (or --scene)");
      palplab::app::add_scene_option(cmd, a->scene, false);
      cmd->add_option("--frames", a->frames, "Close after N frames (0 = run until closed)");
      cmd->add_option("--screenshot", a->screenshot, "Save the last frame as PNG (with --frames)");
      cmd->add_option("--size", a->size, "Window size WIDTHxHEIGHT (default 1280x800)");
      cmd->add_option("--device", a->device,
                      "mouse (default), udp:PORT (a bridge on 127.0.0.1, docs/DEVICES.md) or "
                      "trace:FILE (replay a recorded device track)");
      cmd->add_option("--min-device-rate", a->min_rate,
                      "Refuse a hardware device slower than this (Hz, default 900)");
      cmd->add_option("--record-trace", a->record_trace, "Write the device track to FILE");
      cmd->callback([a, code] { *code = run_view(*a); });
    }};

}  // namespace
