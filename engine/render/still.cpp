#include "engine/render/still.hpp"

#include "common/input_error.hpp"
#include "engine/render/headless.hpp"
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

}  // namespace palplab::render
