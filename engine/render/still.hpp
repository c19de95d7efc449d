#pragma once
// Stills of a scene, headless (EGL): what `palplab render` writes and what a report embeds.
#include <map>
#include <optional>
#include <string>

#include "engine/haptics/scene.hpp"
#include "engine/render/camera.hpp"
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

// The per-region alpha vector of a renderer's DrawOptions from names (unknown names throw
// palplab::InputError listing the regions).
std::vector<float> region_alpha_vector(const engine::SceneGeometry& g,
                                       const std::map<std::string, float>& by_name);

}  // namespace palplab::render
