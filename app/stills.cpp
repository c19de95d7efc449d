#include "app/stills.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>

#include "common/input_error.hpp"
#include "common/write_file.hpp"
#include "engine/render/headless.hpp"
#include "engine/render/still.hpp"
#include "protocols/input_pins.hpp"
#include "prototypes/factory.hpp"
#include "results/sha256.hpp"

namespace palplab::app {

std::pair<int, int> parse_image_size(const std::string& flag, const std::string& text) {
  const std::string bad =
      flag + ": \"" + text + "\": expected WIDTHxHEIGHT in pixels, e.g. 800x600";
  const auto x = text.find('x');
  if (x == std::string::npos) throw InputError(bad);
  int side[2] = {0, 0};
  const std::string parts[2] = {text.substr(0, x), text.substr(x + 1)};
  for (int i = 0; i < 2; ++i) {
    size_t used = 0;
    double v = 0.0;
    try {
      v = std::stod(parts[i], &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != parts[i].size() || !std::isfinite(v)) throw InputError(bad);
    if (v < 16 || v > 8192 || v != std::floor(v))
      throw InputError(flag + ": \"" + text + "\": each side must be a whole number in 16..8192");
    side[i] = static_cast<int>(v);
  }
  return {side[0], side[1]};
}

namespace {

class EglStillMaker : public analysis::StillMaker {
 public:
  std::string unavailable() override {
    if (!ctx_ && why_.empty()) {
      try {
        ctx_.emplace(16, 16);
      } catch (const render::NoDisplayError& e) {
        why_ = e.what();
        if (why_.empty()) why_ = "EGL gave no OpenGL 3.3 core context";
      }
    }
    return ctx_ ? std::string() : why_;
  }

  std::string camera_convention() const override {
    return "Same camera convention for every prototype: aimed at the pressed point (the image "
           "centre), from outside along its outward normal turned by +30° azimuth and +25° "
           "elevation (less, down to none, where another part of the organ would hide the "
           "point), close up: the pressed region and its surroundings (1.5 times the region's "
           "reach from the pressed point, at least 2 cm) fill the image.";
  }

  analysis::StillResult make(const analysis::StillRequest& q) override {
    analysis::StillResult r;
    if (!unavailable().empty()) {
      r.skipped = why_;
      return r;
    }
    // The prototype as run: its file if unchanged (SHA-256, mesh files included), else the JSON
    // stored with the results when that alone defines it (no mesh.file: then its SHA-256 is the
    // text's). An edited prototype would misrepresent the study: no still then.
    std::string file = q.path;
    const bool same_file =
        std::filesystem::exists(q.path) && protocols::prototype_sha256(q.path) == q.sha256;
    if (!same_file) {
      const std::string what =
          std::filesystem::exists(q.path)
              ? "its file " + q.path + " (or its mesh) changed since the run (SHA-256 differs)"
              : "its file " + q.path + " no longer exists";
      if (q.json.empty() || results::sha256_hex(q.json) != q.sha256) {
        r.skipped = what +
                    ", and the JSON stored with the results is not the whole prototype as run "
                    "(its SHA-256 is not the run's, e.g. it names a mesh file)";
        return r;
      }
      file = (stored_dir() / (q.prototype + ".json")).string();
      write_file(file, q.json, "a scratch copy of the stored prototype");
      r.note = "drawn from the prototype JSON stored with the results: " + what;
    }
    std::optional<engine::Scene> scene, rest;
    try {
      scene.emplace(prototypes::build_scene(file));
      rest.emplace(prototypes::build_scene(file));
    } catch (const InputError& e) {
      // e.g. a stored copy in a format this palplab no longer reads: its first problem.
      std::string what = e.what();
      const auto nl = what.find('\n');
      const long more = std::count(what.begin(), what.end(), '\n');
      if (nl != std::string::npos) what = what.substr(0, nl);
      r.skipped = "it does not load in this palplab: " + what +
                  (more > 0 ? " (and " + std::to_string(more) + " more problems)" : "");
      return r;
    }
    render::PressedStill p;
    try {
      p = render::press_for_still(*scene, q.region, q.force, q.hold);
    } catch (const std::invalid_argument& e) {
      r.skipped = std::string("cannot press it: ") + e.what();
      return r;
    }
    const render::PressCamera pc =
        render::camera_facing_press(rest->geometry(), p, q.width, q.height);
    const render::Camera& cam = pc.camera;
    render::StillOptions opt;
    opt.device_position = p.device;
    opt.contact = p.contact;
    render::write_png(q.pressed_png,
                      render::render_still(*ctx_, *scene, cam, q.width, q.height, opt));
    // The same view of the same prototype at rest (a fresh scene: nothing pressed, no marker).
    render::write_png(q.rest_png, render::render_still(*ctx_, *rest, cam, q.width, q.height));
    r.node = p.node;
    r.force_reached = p.force_reached;
    r.force = p.force;
    r.visible_deformation = p.visible_deformation;
    Eigen::Vector3d centre;
    double radius = 0.0;
    render::bounding_sphere(rest->geometry().V, centre, radius);
    const render::CameraMatrices m =
        render::camera_matrices(cam, centre, radius, q.width, q.height);
    r.camera = {{"azimuth_deg", cam.azimuth_deg},
                {"offset_deg", {pc.azimuth_offset_deg, pc.elevation_offset_deg}},
                {"elevation_deg", cam.elevation_deg},
                {"distance", m.distance},
                {"eye", {m.eye.x(), m.eye.y(), m.eye.z()}},
                {"target", {p.point.x(), p.point.y(), p.point.z()}},
                {"fov_y_deg", cam.fov_y_deg},
                {"pressed_point", {p.point.x(), p.point.y(), p.point.z()}},
                {"normal", {p.normal.x(), p.normal.y(), p.normal.z()}}};
    return r;
  }

  ~EglStillMaker() override {
    if (!stored_.empty()) std::filesystem::remove_all(stored_);
  }

 private:
  // A scratch directory for stored prototype copies (removed with the maker).
  const std::filesystem::path& stored_dir() {
    if (stored_.empty()) {
      stored_ =
          std::filesystem::temp_directory_path() / ("palplab_stills_" + std::to_string(::getpid()));
      std::filesystem::create_directories(stored_);
    }
    return stored_;
  }
  std::optional<render::HeadlessContext> ctx_;
  std::string why_;
  std::filesystem::path stored_;
};

}  // namespace

std::shared_ptr<analysis::StillMaker> make_still_maker() {
  return std::make_shared<EglStillMaker>();
}

}  // namespace palplab::app
