#include "app/palpation_ui.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <iostream>
#include <thread>

#include "engine/render/gl.hpp"

namespace palplab::app {

namespace {
double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

UiScene UiScene::of(const engine::Scene& s) {
  UiScene u;
  u.prototype = s.prototype();
  u.geometry = s.geometry();
  for (int r = 0; r < static_cast<int>(u.geometry.region_names.size()); ++r)
    u.thresholds.push_back(s.thresholds(r));
  u.cues = s.config().cues;
  u.coarse_nodes = s.stats().surface_coarse_nodes;
  u.tool = s.tool();
  u.axis = s.config().needle.axis;
  const std::size_t nr = u.geometry.region_names.size();
  if (u.geometry.tissues) {
    u.see_through.assign(nr, 1.0f);
    for (int r : u.geometry.tissues->soft_regions)
      if (r >= 0 && r < static_cast<int>(nr)) u.see_through[r] = 0.15f;
  } else {
    u.see_through.assign(nr, 0.45f);
  }
  return u;
}

PalpationUi::PalpationUi(int width, int height, const std::string& title,
                         std::optional<render::MouseScript> script)
    : script_(std::move(script)) {
  win_ = std::make_unique<render::Window>(width, height, title);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini next to the user's files
  ImGui_ImplGlfw_InitForOpenGL(win_->handle(), true);
  ImGui_ImplOpenGL3_Init("#version 330 core");
  tone_ = std::make_unique<render::ToneCue>();
  t_prev_ = stage_t0_ = now_s();
}

PalpationUi::~PalpationUi() {
  tone_.reset();
  renderer_.reset();
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
}

void PalpationUi::set_scene(UiScene scene) {
  control_.reset();
  renderer_.reset();
  scene_ = std::make_unique<UiScene>(std::move(scene));
  renderer_ = std::make_unique<render::Renderer>(scene_->geometry);
  control_ = std::make_unique<render::MouseControl>(scene_->geometry);
  transparent_ = scene_->cues.transparency;  // the session's cue; T still toggles it
  needle_ = scene_->tool == "needle";
  stage_t0_ = now_s();
  in_message_ = false;
  if (script_) script_->restart();
}

bool PalpationUi::closed() const {
  return win_->should_close();
}
void PalpationUi::request_close() {
  win_->request_close();
}

void PalpationUi::begin_frame() {
  in_ = win_->poll();
  handle_keys();
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
}

void PalpationUi::handle_keys() {
  for (int k = 0; k < in_.n_keys; ++k) {
    if (in_.keys_pressed[k] == GLFW_KEY_W) wireframe_ = !wireframe_;
    if (in_.keys_pressed[k] == GLFW_KEY_T) transparent_ = !transparent_;
    if (in_.keys_pressed[k] == GLFW_KEY_R && control_) control_->release();
    if (in_.keys_pressed[k] == GLFW_KEY_N && scene_ && scene_->tool != "probe") needle_ = !needle_;
    if (in_.keys_pressed[k] == GLFW_KEY_ESCAPE) win_->request_close();
  }
}

void PalpationUi::draw_palpation(engine::MouseDevice* mouse, const engine::MonitoredDevice* monitor,
                                 const engine::Frame* newest, const UiStatus& status) {
  const int fw = win_->width(), fh = win_->height();
  const UiScene& sc = *scene_;
  const engine::SceneGeometry& g = sc.geometry;
  const render::CameraMatrices m = renderer_->matrices(cam_, fw, fh);
  // A script drives the mouse only while a scene is shown; its clock starts with the scene.
  if (script_) {
    in_ = script_->input_at(now_s() - stage_t0_, script_close_);
    handle_keys();  // the script's keys, as the window's
    if (script_close_) win_->request_close();
  }
  const bool ui_mouse = !script_ && ImGui::GetIO().WantCaptureMouse;
  // The mouse has no stylus: the needle's axis is the view direction from the eye through the
  // contact point (where the person looks is where the needle goes in), sent with the tool to
  // the haptic thread (engine/haptics/devices/tool_switch.hpp).
  Eigen::Vector3d needle_axis = sc.axis;
  if (mouse) {
    control_->update(in_, m, cam_, ui_mouse, *mouse);
    if (sc.tool != "probe") {
      const Eigen::Vector3d d = control_->position() - m.eye;
      needle_axis = d.norm() > 1e-9 ? Eigen::Vector3d(d.normalized()) : m.forward;
      mouse->set_tool(needle_, needle_axis);
    }
  } else if (!ui_mouse && in_.middle) {  // another device: the mouse only orbits
    engine::MouseDevice scratch(control_->position());
    control_->update(in_, m, cam_, ui_mouse, scratch);
  }
  // With the visual-deformation cue off the person sees the rest surface.
  if (newest && newest->V.rows() > 0 && sc.cues.visual_deformation)
    renderer_->update_surface(newest->V, newest->F, sc.coarse_nodes);
  const engine::RenderedSummary s = monitor ? monitor->last_rendered() : engine::RenderedSummary{};
  render::DrawOptions opt;
  opt.wireframe = wireframe_;
  if (transparent_) opt.region_alpha = sc.see_through;
  opt.device_position = monitor ? monitor->last_position() : control_->position();
  opt.contact = s.contact;
  if (mouse ? needle_ : sc.tool == "needle") opt.needle_axis = needle_axis;
  renderer_->draw(cam_, fw, fh, opt);
  // The ST cue (the scene's audio cue: force >= ST of the contact region, cue on): always a
  // yellow border flash, and a tone where there is a sound card.
  if (s.audio) {
    const double b = 12.0;
    const std::array<float, 4> c = {1.0f, 0.85f, 0.1f, 0.85f};
    renderer_->overlay_rect(fw, fh, 0, 0, fw, b, c);
    renderer_->overlay_rect(fw, fh, 0, fh - b, fw, fh, c);
    renderer_->overlay_rect(fw, fh, 0, 0, b, fh, c);
    renderer_->overlay_rect(fw, fh, fw - b, 0, fw, fh, c);
  }
  // (The tone is switched by the haptic thread: ToneSwitch.)
  if (!tone_->available() && !tone_reported_ && sc.cues.audio) {
    std::cerr << "palplab: no ST tone (" << tone_->error() << "); the flash shows the cue\n";
    tone_reported_ = true;
  }

  ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_Always);
  ImGui::SetNextWindowSize(ImVec2(380, 0), ImGuiCond_Always);
  ImGui::Begin("palplab", nullptr,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  ImGui::Text("prototype %s", sc.prototype.c_str());
  if (mouse && sc.tool != "probe")
    ImGui::Text("tool: %s (N switches finger / needle)", needle_ ? "needle" : "finger");
  for (const auto& l : status.lines) ImGui::TextUnformatted(l.c_str());
  if (status.timer >= 0.0) {
    ImGui::ProgressBar(
        static_cast<float>(std::clamp(status.timer / std::max(status.timer_total, 1e-9), 0.0, 1.0)),
        ImVec2(300, 0), "");
    ImGui::SameLine();
    ImGui::Text("%.0f / %.0f s", status.timer, status.timer_total);
  }
  const int r = s.contact_region;
  const std::string region =
      r >= 0 && r < static_cast<int>(g.region_names.size()) ? g.region_names[r] : "-";
  ImGui::Text("contact: %s   region: %s", s.contact ? "yes" : "no", region.c_str());
  const engine::Thresholds t =
      r >= 0 && r < static_cast<int>(sc.thresholds.size())
          ? sc.thresholds[r]
          : (sc.thresholds.empty() ? engine::Thresholds{} : sc.thresholds[0]);
  ImGui::Text("cues: haptic %s, deformation %s, ST tone/flash %s%s", sc.cues.haptic ? "on" : "off",
              sc.cues.visual_deformation ? "on" : "off", sc.cues.audio ? "on" : "off",
              sc.cues.audio && !tone_->available() ? " (no sound card: flash)" : "");
  if (sc.cues.haptic) {
    const double f = s.force.norm();
    ImGui::Text("force %.2f N (peak %.2f N)   depth %.1f mm", f, s.peak_force,
                control_->depth() * 1e3);
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
    for (const auto& mk : marks) {
      const float x = p0.x + static_cast<float>(mk.v) / full * w;
      dl->AddLine(ImVec2(x, p0.y - 2), ImVec2(x, p0.y + h + 2), IM_COL32(255, 255, 255, 255), 2.0f);
      dl->AddText(ImVec2(x - 8, p0.y + h + 2), IM_COL32(255, 255, 255, 255), mk.name);
    }
    ImGui::Dummy(ImVec2(w, h + 18));
    ImGui::Text("ST %.2f  MPF %.2f  SFT %.2f N", t.st, t.mpf, t.sft);
  } else {
    ImGui::Text("haptic cue off: no force shown   depth %.1f mm", control_->depth() * 1e3);
  }
  ImGui::Separator();
  std::vector<double> sorted(frame_ms_.begin(), frame_ms_.end());
  std::sort(sorted.begin(), sorted.end());
  ImGui::Text("frame %.1f ms median, %.1f ms max", sorted.empty() ? 0.0 : sorted[sorted.size() / 2],
              sorted.empty() ? 0.0 : sorted.back());
  if (status.loop) {
    const auto& st = *status.loop;
    ImGui::Text("haptic loop %.0f Hz: period %.0f us median,",
                1e6 / std::max(st.period_median_us, 1.0), st.period_median_us);
    ImGui::Text("  %.0f us p99, step %.0f us median, %ld overruns", st.period_p99_us,
                st.step_median_us, st.overruns);
  } else {
    ImGui::Text("haptic loop: measuring ...");
  }
  ImGui::Separator();
  ImGui::Checkbox("wireframe (W)", &wireframe_);
  ImGui::SameLine();
  ImGui::Checkbox("transparent (T)", &transparent_);
  ImGui::TextDisabled("L-drag move, wheel/R-drag press, M-drag orbit, R release");
  ImGui::End();
}

bool PalpationUi::draw_message(const std::string& title, const std::string& text,
                               const std::string& button) {
  const int fw = win_->width(), fh = win_->height();
  if (!in_message_) {
    in_message_ = true;
    stage_t0_ = now_s();
  }
  tone_->set_on(false);
  if (renderer_) {
    renderer_->draw(cam_, fw, fh, render::DrawOptions{});
  } else {
    glClearColor(1.0f, 1.0f, 1.0f, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT);
  }
  ImGui::SetNextWindowPos(ImVec2(fw * 0.5f, fh * 0.5f), ImGuiCond_Always, ImVec2(0.5f, 0.5f));
  ImGui::SetNextWindowSize(ImVec2(std::min(560.0f, fw - 20.0f), 0), ImGuiCond_Always);
  ImGui::Begin(title.c_str(), nullptr,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  ImGui::TextWrapped("%s", text.c_str());
  ImGui::Separator();
  bool go = ImGui::Button(button.c_str());
  ImGui::SameLine();
  ImGui::TextDisabled("(Space or Enter; close the window to stop)");
  ImGui::End();
  for (int k = 0; k < in_.n_keys; ++k)
    if (in_.keys_pressed[k] == GLFW_KEY_SPACE || in_.keys_pressed[k] == GLFW_KEY_ENTER) go = true;
  if (script_ && now_s() - stage_t0_ >= script_->instructions_seconds()) go = true;
  if (go) in_message_ = false;
  return go;
}

void PalpationUi::end_frame(const std::string& screenshot) {
  ImGui::Render();
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  ++frame_no_;
  if (!screenshot.empty()) {
    render::write_png(screenshot, win_->read_back_buffer());
    std::cout << "wrote " << screenshot << " (frame " << frame_no_ << ", " << win_->width() << "x"
              << win_->height() << ")\n";
  }
  win_->swap();
  // At most 60 frames/s even where swap does not wait for a vertical blank (Xvfb, some
  // drivers): the frames of a busy window would take the CPU from the haptic thread.
  std::this_thread::sleep_until(std::chrono::steady_clock::time_point(
      std::chrono::duration_cast<std::chrono::steady_clock::duration>(
          std::chrono::duration<double>(t_prev_ + 1.0 / 60.0))));
  const double t = now_s();
  frame_ms_.push_back((t - t_prev_) * 1e3);
  if (frame_ms_.size() > 120) frame_ms_.pop_front();
  t_prev_ = t;
}

}  // namespace palplab::app
