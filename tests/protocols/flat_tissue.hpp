#pragma once
// Flat test tissue for the participant-model tests: a 0.2 m square surface at z = 0 with linear
// stiffness, a disc-shaped "feature" region (id 0) around `feature`, optional visible
// deformation and a sound at ST. It renders exactly what a Scene renders (force, contact,
// region, deformation, audio) with known physics.
#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "protocols/participants/model.hpp"

namespace palplab::protocols::participants::fixtures {

struct FlatTissue {
  double start_height = 0.05;  // m above the surface where the hand starts
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> V, N;
  std::vector<int> region;
  Eigen::Vector3d feature{0.05, 0.05, 0.0};
  double k = 800.0;  // N/m
  // Optional stiffness that varies from place to place: within the feature disc but farther than
  // core_radius from its centre the tissue is softer, k_edge (0 = uniform k).
  double k_edge = 0.0;       // N/m
  double core_radius = 0.0;  // m
  // Optional stiffness near the start: within start_radius (in the plane) of the point below the
  // start position the tissue has stiffness k_start (0 = uniform k), so that landmarks on the
  // route feel different.
  double k_start = 0.0;       // N/m
  double start_radius = 0.0;  // m
  double st = 2.3;            // N
  bool visual = true, audio = true;

  FlatTissue() {
    const int n = 41;
    V.resize(n * n, 3);
    N.resize(n * n, 3);
    region.resize(n * n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        int v = i * n + j;
        V.row(v) << -0.1 + 0.2 * i / (n - 1), -0.1 + 0.2 * j / (n - 1), 0.0;
        N.row(v) << 0, 0, 1;
        region[v] = (V.row(v).transpose() - feature).norm() < 0.015 ? 0 : 1;
      }
  }
  SurfaceView view() const {
    SurfaceView s;
    s.V = &V;
    s.N = &N;
    s.vertex_region = &region;
    s.feature_region = 0;
    s.feature_centroid = feature;
    s.start_position = {0.0, 0.0, start_height};
    return s;
  }
  double stiffness(const Eigen::Vector3d& x) const {
    const double r = (Eigen::Vector3d(x.x(), x.y(), 0) - feature).norm();
    if (k_start > 0 && std::hypot(x.x(), x.y()) < start_radius) return k_start;
    return k_edge > 0 && r >= core_radius && r < 0.015 ? k_edge : k;
  }
  Percept render(double t, const Eigen::Vector3d& x) const {
    Percept p;
    p.t = t;
    const double depth = -x.z();
    const bool inside = std::abs(x.x()) <= 0.1 && std::abs(x.y()) <= 0.1;
    if (depth > 0 && inside) {
      p.contact = true;
      p.force = Eigen::Vector3d(0, 0, stiffness(x) * depth);
      p.contact_region = (Eigen::Vector3d(x.x(), x.y(), 0) - feature).norm() < 0.015 ? 0 : 1;
      p.visible_deformation = visual ? depth : 0.0;
      p.audio = audio && p.force.norm() >= st;
    }
    return p;
  }
};

}  // namespace palplab::protocols::participants::fixtures
