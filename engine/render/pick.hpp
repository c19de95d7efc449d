#pragma once
// Picking: where a ray from the camera meets the rest surface (mouse as the device).
#include <Eigen/Core>
#include <optional>

#include "engine/haptics/scene.hpp"

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

}  // namespace palplab::render
