#pragma once
// Picking: where a ray from the camera meets the rest surface (mouse as the device).
#include <Eigen/Core>
#include <optional>

#include "engine/haptics/scene.hpp"
#include "engine/render/camera.hpp"

namespace palplab::render {

struct SurfaceHit {
  double distance = 0.0;                            // m along the ray
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  // m
  int face = -1;
};

// Nearest intersection of the ray (origin, unit dir) with the faces of g (Moller-Trumbore, both
// sides); none when it misses. O(#F): ~0.1 ms for the 12k faces of prototype B.
std::optional<SurfaceHit> pick_surface(const engine::SceneGeometry& g,
                                       const Eigen::Vector3d& origin, const Eigen::Vector3d& dir);

// The pixel (on a grid of `step` px, `margin` px from the edges) whose cursor ray meets the rest
// surface most nearly head-on (largest |cos| between the ray and the face normal), and that
// cosine: where a scripted press along the view direction goes straight into the tissue (tests,
// demonstrations of the mouse device). None when no ray hits the surface.
struct HeadOnPixel {
  int x = 0, y = 0;   // px, origin top-left
  double cosine = 0;  // in [0, 1]
};
std::optional<HeadOnPixel> head_on_pixel(const engine::SceneGeometry& g, const CameraMatrices& m,
                                         int step = 6, int margin = 10);

}  // namespace palplab::render
