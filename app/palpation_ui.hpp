#pragma once
// The palpation window shared by `palplab view` and human sessions in the window (`palplab run
// --human --device mouse`): the GLFW window with its Dear ImGui panel, the renderer of the
// current scene, the mouse as the device (render::MouseControl -> engine::MouseDevice), the force
// bar against the contact region's ST/MPF/SFT, the ST cue as a border flash and a tone
// (render::ToneCue; silent where there is no sound card), frame and haptic-loop timing.
// Main thread only (GLFW, OpenGL).
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "engine/haptics/clock.hpp"
#include "engine/haptics/devices/monitored_device.hpp"
#include "engine/haptics/scene_config.hpp"
#include "engine/render/camera.hpp"
#include "engine/render/mouse_control.hpp"
#include "engine/render/mouse_script.hpp"
#include "engine/render/renderer.hpp"
#include "engine/render/tone_cue.hpp"
#include "engine/render/window.hpp"

namespace palplab::app {

// What the window needs of a scene: a copy (the scene may end before the window redraws).
struct UiScene {
  std::string prototype;
  engine::SceneGeometry geometry;
  std::vector<engine::Thresholds> thresholds;  // per region
  engine::Cues cues;
  long coarse_nodes = 0;
  // Opacity per region with transparency on (T, or the scene's transparency cue): a needle
  // scene's soft tissues 0.15 (bone, target and needle show through; each soft interface is drawn
  // from both sides), else every region 0.45.
  std::vector<float> see_through;
  // The tool at the start ("needle": the needle is drawn from the contact point back along
  // `axis`, the stylus axis).
  std::string tool;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitY();
  static UiScene of(const engine::Scene& s);
};

// Extra lines of the panel (session, timer) and the haptic loop's last stats.
struct UiStatus {
  std::vector<std::string> lines;
  std::optional<engine::RealtimeStats> loop;
  double timer = -1.0, timer_total = 0.0;  // s elapsed / planned; < 0 = no timer
};

// Switches the ST tone from the haptic thread at every step (an atomic store), so the tone
// follows the force within a step and the tone's 5 ms block, not a window frame.
class ToneSwitch : public engine::Device {
 public:
  ToneSwitch(engine::Device& inner, render::ToneCue& tone) : inner_(inner), tone_(tone) {}
  engine::DeviceInput read(double t) override { return inner_.read(t); }
  void write(const engine::Rendered& r) override {
    inner_.write(r);
    tone_.set_on(r.audio);
  }
  bool finished() const override { return inner_.finished(); }
  std::vector<engine::DeviceEvent> take_events() override { return inner_.take_events(); }
  long samples_received() const override { return inner_.samples_received(); }

 private:
  engine::Device& inner_;
  render::ToneCue& tone_;
};

class PalpationUi {
 public:
  // Throws render::NoWindowError without a display. `script`: scripted input in place of the
  // window's mouse (tests, demonstrations).
  PalpationUi(int width, int height, const std::string& title,
              std::optional<render::MouseScript> script);
  ~PalpationUi();

  // A new scene (a new session): renderer and mouse control for its geometry; the script
  // restarts. `mouse` (may be null) is the device the mouse drives.
  void set_scene(UiScene scene);
  bool has_scene() const { return scene_ != nullptr; }

  // One frame. begin_frame polls the input (script or window) and starts the panel; then either
  // draw_palpation (a scene, the mouse driving `mouse`) or draw_message; end_frame swaps and
  // paces to 60 frames/s. `screenshot` (non-empty): the frame is saved as PNG before the swap.
  void begin_frame();
  void draw_palpation(engine::MouseDevice* mouse, const engine::MonitoredDevice* monitor,
                      const engine::Frame* newest, const UiStatus& status);
  // A text screen (instructions between sessions) with a button; true when it was pressed
  // (click, Space or Enter; a script presses it after its instructions_seconds).
  bool draw_message(const std::string& title, const std::string& text, const std::string& button);
  void end_frame(const std::string& screenshot = "");

  bool closed() const;  // the window's close button, Esc, or the script's close
  void request_close();
  long frames() const { return frame_no_; }
  render::ToneCue& tone() { return *tone_; }

 private:
  void handle_keys();  // this frame's keys in in_ (W, T, R, N, Esc)
  std::unique_ptr<render::Window> win_;
  std::unique_ptr<render::Renderer> renderer_;
  std::unique_ptr<UiScene> scene_;
  std::unique_ptr<render::MouseControl> control_;
  std::unique_ptr<render::ToneCue> tone_;
  std::optional<render::MouseScript> script_;
  render::Camera cam_;
  render::WindowInput in_;  // this frame's: the window's, or the script's during a scene
  bool script_close_ = false;
  double stage_t0_ = 0.0;  // s (steady clock) when the current scene or message started
  bool in_message_ = false;
  bool wireframe_ = false, transparent_ = false;
  // A multi-tool scene's tool with the mouse as the device: N toggles finger / needle; the
  // needle goes in along the camera's view direction through the contact point.
  bool needle_ = false;
  std::deque<double> frame_ms_;
  double t_prev_ = 0.0;
  long frame_no_ = 0;
  bool tone_reported_ = false;
};

}  // namespace palplab::app
