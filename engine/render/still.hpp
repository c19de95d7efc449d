#pragma once
// Stills of a scene, headless (EGL): what `palplab render` writes and what a report embeds.
#include <map>
#include <optional>
#include <string>

#include "engine/haptics/scene.hpp"
#include "engine/render/camera.hpp"
#include "engine/render/headless.hpp"
#include "engine/render/image.hpp"

namespace palplab::render {

struct StillOptions {
  bool wireframe = false;
  // Opacity per region name ("*" = every region), e.g. {"body", 0.35}.
  std::map<std::string, float> region_alpha;
  // Where the HCP is drawn (m); none = no marker. `contact` colours it red.
  std::optional<Eigen::Vector3d> device_position;
  bool contact = false;
};

// Renders the scene's current (possibly deformed, refined) surface as it stands — the scene is
// only read. Creates a headless EGL context for the call (throws NoDisplayError without one).
Image render_still(const engine::Scene& scene, const Camera& camera, int width, int height,
                   const StillOptions& options = {});

// The same, drawn with an existing context (resized to width x height): a caller making several
// stills (a report) creates the EGL context once.
Image render_still(HeadlessContext& ctx, const engine::Scene& scene, const Camera& camera,
                   int width, int height, const StillOptions& options = {});

// A scene brought under a press for a still: the one press script (engine/haptics/press.hpp) at
// a surface node, run on the lock-step clock until the end of its hold, so the scene then shows
// the organ under the target force.
struct PressedStill {
  int node = -1;                                      // surface node pressed
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    // m, its rest position
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // outward unit normal there
  Eigen::Vector3d device = Eigen::Vector3d::Zero();   // m, the HCP at the still
  bool contact = false;                               // in contact at the still
  bool force_reached = false;                         // the press reached `force`
  double force = 0.0;                                 // N, |F| on the hand at the still
  double visible_deformation = 0.0;                   // m, as the scene reports it
  double region_reach = 0.0;  // m, farthest rest vertex of the pressed region from `point`
};
// `what` is a region name (its node nearest the region's centroid) or a surface node index
// (engine::press_node; throws std::invalid_argument naming the regions otherwise). force in N,
// hold in s. Steps `scene` (it is left pressed).
PressedStill press_for_still(engine::Scene& scene, const std::string& what, double force,
                             double hold);

// The camera convention of stills that compare prototypes under one press: aimed at the pressed
// rest point (it lands on the image centre), from outside along its outward normal turned by
// (azimuth, elevation) offsets, the first of (+30, +25), (+15, +12), (0, 0) degrees from which
// the rest surface `g` does not hide the point (elevation kept within [-85, 85]); close up: at
// the distance where a sphere around the point of 1.5 times the pressed region's reach (its
// farthest vertex from the point; at least 2 cm) fills the image.
struct PressCamera {
  Camera camera;
  double azimuth_offset_deg = 0.0, elevation_offset_deg = 0.0;  // the offsets used
};
PressCamera camera_facing_press(const engine::SceneGeometry& g, const PressedStill& press,
                                int width, int height);

// The per-region alpha vector of a renderer's DrawOptions from names (unknown names throw
// palplab::InputError listing the regions).
std::vector<float> region_alpha_vector(const engine::SceneGeometry& g,
                                       const std::map<std::string, float>& by_name);

}  // namespace palplab::render
