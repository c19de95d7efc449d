#include "engine/render/still.hpp"

#include <algorithm>
#include <cmath>

#include "common/input_error.hpp"
#include "engine/haptics/clock.hpp"
#include "engine/haptics/press.hpp"
#include "engine/render/headless.hpp"
#include "engine/render/pick.hpp"
#include "engine/render/renderer.hpp"

namespace palplab::render {

std::vector<float> region_alpha_vector(const engine::SceneGeometry& g,
                                       const std::map<std::string, float>& by_name) {
  std::vector<float> a(g.region_names.size(), 1.0f);
  for (const auto& [name, alpha] : by_name) {
    if (!(alpha >= 0.0f && alpha <= 1.0f))
      throw InputError("opacity of region \"" + name + "\": expected a value in [0, 1], got " +
                       std::to_string(alpha));
    if (name == "*") {
      for (float& x : a) x = alpha;
      continue;
    }
    const int r = g.region_index(name);
    if (r < 0) {
      std::string names;
      for (const auto& n : g.region_names) names += (names.empty() ? "" : ", ") + n;
      throw InputError("unknown region \"" + name +
                       "\" (this scene has: " + (names.empty() ? "none" : names) + ")");
    }
    a[r] = alpha;
  }
  return a;
}

Image render_still(const engine::Scene& scene, const Camera& camera, int width, int height,
                   const StillOptions& options) {
  if (width < 1 || height < 1 || width > 8192 || height > 8192)
    throw InputError("image size " + std::to_string(width) + "x" + std::to_string(height) +
                     ": expected 1..8192 pixels per side");
  HeadlessContext ctx(width, height);
  return render_still(ctx, scene, camera, width, height, options);
}

Image render_still(HeadlessContext& ctx, const engine::Scene& scene, const Camera& camera,
                   int width, int height, const StillOptions& options) {
  if (width < 1 || height < 1 || width > 8192 || height > 8192)
    throw InputError("image size " + std::to_string(width) + "x" + std::to_string(height) +
                     ": expected 1..8192 pixels per side");
  ctx.resize(width, height);
  Image img;
  {
    Renderer r(scene.geometry());
    RowMatX3d V;
    RowMatX3i F;
    scene.current_surface(V, F);
    r.update_surface(V, F, scene.stats().surface_coarse_nodes);
    DrawOptions d;
    d.wireframe = options.wireframe;
    d.region_alpha = region_alpha_vector(scene.geometry(), options.region_alpha);
    d.device_position = options.device_position;
    d.contact = options.contact;
    ctx.bind();
    r.draw(camera, width, height, d);
    img = ctx.read_pixels();
  }
  return img;
}

namespace {

// Runs the press script and stops at the end of its hold (the still shows the target force).
class UntilHoldEnds : public engine::Device {
 public:
  explicit UntilHoldEnds(engine::PressDevice& p) : press_(p) {}
  engine::DeviceInput read(double t) override { return press_.read(t); }
  void write(const engine::Rendered& r) override {
    press_.write(r);
    contact_ = r.contact;
    force_ = r.force.norm();
    deformation_ = r.visible_deformation;
  }
  bool finished() const override {
    return press_.phase() == engine::PressPhase::withdraw ||
           press_.phase() == engine::PressPhase::release ||
           press_.phase() == engine::PressPhase::done;
  }
  bool contact_ = false;
  double force_ = 0.0, deformation_ = 0.0;

 private:
  engine::PressDevice& press_;
};

}  // namespace

PressedStill press_for_still(engine::Scene& scene, const std::string& what, double force,
                             double hold) {
  PressedStill out;
  out.node = engine::press_node(scene.geometry(), what);
  engine::PressDevice press(engine::press_at(scene.geometry(), out.node, force, hold, 0.0));
  out.point = press.spec().point;
  out.normal = press.spec().normal;
  const auto& g = scene.geometry();
  const int region = g.vertex_region.empty() ? -1 : g.vertex_region[out.node];
  for (long v = 0; v < g.V.rows() && region >= 0; ++v)
    if (g.vertex_region[v] == region)
      out.region_reach = std::max(out.region_reach, (g.V.row(v).transpose() - out.point).norm());
  UntilHoldEnds dev(press);
  engine::LockstepOptions lo;
  lo.duration = press.spec().max_approach_time + hold + 1.0;
  lo.frame_period = 0.0;
  engine::run_lockstep(scene, dev, lo);
  out.device = scene.last_sample().x;
  out.contact = dev.contact_;
  out.force_reached = press.force_reached();
  out.force = dev.force_;
  out.visible_deformation = dev.deformation_;
  return out;
}

PressCamera camera_facing_press(const engine::SceneGeometry& g, const PressedStill& press,
                                int width, int height) {
  constexpr double kDeg = 180.0 / 3.14159265358979323846;
  const Eigen::Vector3d n = press.normal.normalized();
  const double az0 = std::atan2(n.y(), n.x()) * kDeg;
  const double el0 = std::asin(std::clamp(n.z(), -1.0, 1.0)) * kDeg;
  PressCamera pc;
  // The default camera's offsets show the surface's relief; nearer the normal when another part
  // of the organ (a horn curling over an ovary) would hide the pressed point.
  for (const auto& [daz, del] :
       {std::pair{30.0, 25.0}, std::pair{15.0, 12.0}, std::pair{0.0, 0.0}}) {
    Camera cam;
    cam.target = press.point;
    cam.azimuth_deg = az0 + daz;
    cam.elevation_deg = std::clamp(el0 + del, -85.0, 85.0);
    cam.distance = fit_distance(cam, std::max(0.02, 1.5 * press.region_reach), width, height);
    pc = {cam, daz, del};
    // Only the eye is used (the depth range of a zero-radius scene is meaningless).
    const CameraMatrices m = camera_matrices(cam, press.point, 0.0, width, height);
    const double to_point = (press.point - m.eye).norm();
    const auto hit = pick_surface(g, m.eye, (press.point - m.eye) / to_point);
    if (!hit || hit->distance > to_point - 2e-3) break;  // nothing in front of the point
  }
  return pc;
}

}  // namespace palplab::render
