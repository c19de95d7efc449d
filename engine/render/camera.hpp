#pragma once
// The orbit camera of the renderer and the matrices it yields. Pure maths (no OpenGL), so tests
// can predict where a point lands on the image.
#include <Eigen/Core>
#include <optional>

#include "engine/haptics/scene.hpp"

namespace palplab::render {

// Orbit camera around a target. The organ frame has +z up (the prototypes fix the tissue below a
// height in z). Azimuth is measured about +z from +x towards +y, elevation above the xy plane.
struct Camera {
  double azimuth_deg = 30.0;
  double elevation_deg = 25.0;
  double distance = 0.0;                  // m from the target; 0 = fit the rest surface in view
  std::optional<Eigen::Vector3d> target;  // m; default: centre of the rest bounding box
  double fov_y_deg = 35.0;                // vertical field of view
};

struct CameraMatrices {
  Eigen::Matrix4d view = Eigen::Matrix4d::Identity();  // world (m) -> eye
  Eigen::Matrix4d proj = Eigen::Matrix4d::Identity();  // eye -> clip
  Eigen::Vector3d eye = Eigen::Vector3d::Zero();       // m, camera position
  Eigen::Vector3d target = Eigen::Vector3d::Zero();    // m
  Eigen::Vector3d forward = Eigen::Vector3d::UnitX();  // unit view direction (eye -> target)
  double distance = 0.0;                               // m
  int width = 1, height = 1;                           // px

  // Pixel coordinates of a world point (x right, y down, origin at the top-left corner of the
  // image, pixel centres at +0.5) and its eye-space depth (m, > 0 in front of the camera).
  Eigen::Vector2d project(const Eigen::Vector3d& p, double* depth = nullptr) const;
  // The world-space ray through pixel (x, y): origin at the eye, unit direction.
  void unproject(double x, double y, Eigen::Vector3d& origin, Eigen::Vector3d& dir) const;
};

// Bounding sphere of a point set: centre of the bounding box and the largest distance to it (m).
void bounding_sphere(const Eigen::Ref<const mesh::Positions>& V, Eigen::Vector3d& centre,
                     double& radius);

// The camera distance (m) at which a sphere of `radius` around the target fills ~90% of the
// smaller side of a width x height image (what a distance of 0 means below).
double fit_distance(const Camera& cam, double radius, int width, int height);

// The matrices of `cam` for an image of width x height pixels over a surface whose rest bounding
// sphere is (centre, radius). A distance of 0 places the camera so the sphere fills ~90% of the
// smaller image side.
CameraMatrices camera_matrices(const Camera& cam, const Eigen::Vector3d& centre, double radius,
                               int width, int height);

}  // namespace palplab::render
