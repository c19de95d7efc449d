#include "engine/render/pick.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <limits>

namespace palplab::render {

std::optional<SurfaceHit> pick_surface(const engine::SceneGeometry& g,
                                       const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) {
  std::optional<SurfaceHit> best;
  double best_t = std::numeric_limits<double>::infinity();
  for (long f = 0; f < g.F.rows(); ++f) {
    const Eigen::Vector3d a = g.V.row(g.F(f, 0)), b = g.V.row(g.F(f, 1)), c = g.V.row(g.F(f, 2));
    const Eigen::Vector3d e1 = b - a, e2 = c - a;
    const Eigen::Vector3d p = dir.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-18) continue;
    const double inv = 1.0 / det;
    const Eigen::Vector3d s = origin - a;
    const double u = s.dot(p) * inv;
    if (u < 0.0 || u > 1.0) continue;
    const Eigen::Vector3d q = s.cross(e1);
    const double v = dir.dot(q) * inv;
    if (v < 0.0 || u + v > 1.0) continue;
    const double t = e2.dot(q) * inv;
    if (t > 0.0 && t < best_t) {
      best_t = t;
      best = SurfaceHit{t, origin + t * dir, static_cast<int>(f)};
    }
  }
  return best;
}

std::optional<HeadOnPixel> head_on_pixel(const engine::SceneGeometry& g, const CameraMatrices& m,
                                         int step, int margin) {
  std::optional<HeadOnPixel> best;
  for (int y = margin; y < m.height - margin; y += step)
    for (int x = margin; x < m.width - margin; x += step) {
      Eigen::Vector3d o, d;
      m.unproject(x, y, o, d);
      const auto h = pick_surface(g, o, d);
      if (!h) continue;
      const Eigen::Vector3d a = g.V.row(g.F(h->face, 0)), b = g.V.row(g.F(h->face, 1)),
                            c = g.V.row(g.F(h->face, 2));
      const double cs = std::abs((b - a).cross(c - a).normalized().dot(d));
      if (!best || cs > best->cosine) best = HeadOnPixel{x, y, cs};
    }
  return best;
}

}  // namespace palplab::render
