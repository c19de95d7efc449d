#include "engine/render/mouse_control.hpp"

#include <algorithm>

#include "engine/render/pick.hpp"

namespace palplab::render {

MouseControl::MouseControl(const engine::SceneGeometry& g) : g_(g) {
  const int n0 = g.nearest_node(g.start_position);
  hit_ = g.V.row(n0).transpose();
  ray_ = -g.N.row(n0).transpose();
}

Eigen::Vector3d MouseControl::start_position(const engine::SceneGeometry& g) {
  MouseControl c(g);
  return c.position();
}

void MouseControl::update(const WindowInput& in, const CameraMatrices& m, Camera& cam,
                          bool ui_has_mouse, engine::MouseDevice& device) {
  const double dx = have_last_ ? in.mouse_x - last_x_ : 0.0;
  const double dy = have_last_ ? in.mouse_y - last_y_ : 0.0;
  if (!ui_has_mouse) {
    if (in.left) {
      Eigen::Vector3d o, d;
      m.unproject(in.mouse_x, in.mouse_y, o, d);
      if (auto h = pick_surface(g_, o, d)) {
        hit_ = h->point;
        ray_ = d;
      }
    }
    if (in.right) depth_ += dy * kRightDragStep;
    if (in.middle) {
      cam.azimuth_deg -= dx * 0.3;
      cam.elevation_deg = std::clamp(cam.elevation_deg + dy * 0.3, -89.0, 89.0);
    }
    depth_ += in.scroll * kWheelStep;
  }
  depth_ = std::clamp(depth_, -0.01, 0.05);
  last_x_ = in.mouse_x;
  last_y_ = in.mouse_y;
  have_last_ = true;
  device.set_position(position(), in.left);
}

}  // namespace palplab::render
