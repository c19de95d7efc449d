#pragma once
// The mouse as the haptic device: how the window's mouse input becomes the contact point that
// engine::MouseDevice hands to the haptic loop. One implementation for `palplab view` and for
// human sessions in the window (`run --human --device mouse`).
//
//   left drag    the contact point follows the cursor over the REST surface (picked along the
//                cursor ray), kept at the current press depth along that ray
//   wheel        presses in (+) / backs out (-) along the view ray, 1 mm per notch
//   right drag   presses in (drag down) / backs out (drag up), 0.1 mm per pixel
//   middle drag  orbits the camera (0.3 degrees per pixel)
//   release()    back to 2 mm outside the surface
// The depth is limited to [-10, +50] mm about the picked surface point.
#include <Eigen/Core>

#include "engine/haptics/devices/mouse_device.hpp"
#include "engine/haptics/scene.hpp"
#include "engine/render/camera.hpp"
#include "engine/render/window.hpp"

namespace palplab::render {

class MouseControl {
 public:
  static constexpr double kStartDepth = -0.002;   // m: 2 mm outside the surface
  static constexpr double kWheelStep = 1e-3;      // m per wheel notch
  static constexpr double kRightDragStep = 1e-4;  // m per pixel

  // Starts 2 mm outside the surface node nearest to the scene's start position, along its
  // outward normal.
  explicit MouseControl(const engine::SceneGeometry& g);
  // Where it starts (m): what a session's device holds before the first window frame.
  static Eigen::Vector3d start_position(const engine::SceneGeometry& g);

  // One window frame: `in` the frame's input, `m` the camera of the frame, `ui_has_mouse` when
  // the panel takes the mouse (then only the wheel is ignored too). Updates `device`.
  void update(const WindowInput& in, const CameraMatrices& m, Camera& cam, bool ui_has_mouse,
              engine::MouseDevice& device);
  void release() { depth_ = kStartDepth; }
  Eigen::Vector3d position() const { return hit_ + depth_ * ray_; }
  double depth() const { return depth_; }  // m past the picked surface point (< 0 outside)
  const Eigen::Vector3d& surface_point() const { return hit_; }

 private:
  const engine::SceneGeometry& g_;
  Eigen::Vector3d hit_, ray_;
  double depth_ = kStartDepth;
  double last_x_ = 0.0, last_y_ = 0.0;
  bool have_last_ = false;
};

}  // namespace palplab::render
