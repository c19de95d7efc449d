#pragma once
// What the tests of rendered images share (tests/render, tests/cli_render, tests/cli_report):
// which pixels are the white background, the organ's coverage and centroid, and how many pixels
// changed between two stills near a point and far from it.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <cstdlib>

#include "engine/render/camera.hpp"
#include "engine/render/image.hpp"

namespace palplab::testing {

// The renderer's background is white; anything drawn is darker in some channel.
inline bool is_background(const std::uint8_t* p) {
  return p[0] > 250 && p[1] > 250 && p[2] > 250;
}

// Pixels that are not background: count and centroid (px, pixel centres at +0.5).
struct Coverage {
  long count = 0;
  double cx = 0.0, cy = 0.0;
};
inline Coverage coverage(const render::Image& img) {
  Coverage c;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      if (!is_background(img.pixel(x, y))) {
        ++c.count;
        c.cx += x + 0.5;
        c.cy += y + 0.5;
      }
  if (c.count) {
    c.cx /= c.count;
    c.cy /= c.count;
  }
  return c;
}

// Pixels of two images of the same size whose colours differ by more than `threshold` (sum of
// |difference| over R, G and B: 24 is above MSAA edge noise), split by their distance from
// `centre` (px): within `radius` is near, beyond it far.
struct PixelChange {
  long near = 0, far = 0;
  long total() const { return near + far; }
};
inline PixelChange changed_pixels(const render::Image& a, const render::Image& b,
                                  const Eigen::Vector2d& centre = Eigen::Vector2d::Zero(),
                                  double radius = INFINITY, int threshold = 24) {
  PixelChange c;
  if (a.width != b.width || a.height != b.height) return {-1, -1};
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      const auto* p = a.pixel(x, y);
      const auto* q = b.pixel(x, y);
      if (std::abs(p[0] - q[0]) + std::abs(p[1] - q[1]) + std::abs(p[2] - q[2]) <= threshold)
        continue;
      (std::hypot(x + 0.5 - centre.x(), y + 0.5 - centre.y()) <= radius ? c.near : c.far) += 1;
    }
  return c;
}

// How many pixels a length of `metres` at world point p spans sideways on the image of m.
inline double pixels_spanned(const render::CameraMatrices& m, const Eigen::Vector3d& p,
                             double metres) {
  const Eigen::Vector3d side = m.view.block<1, 3>(0, 0).transpose();  // camera right, world
  return (m.project(p + metres * side) - m.project(p)).norm();
}

}  // namespace palplab::testing
