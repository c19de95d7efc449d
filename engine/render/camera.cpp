#include "engine/render/camera.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace palplab::render {

namespace {
constexpr double kPi = 3.14159265358979323846;
}

void bounding_sphere(const Eigen::Ref<const mesh::Positions>& V, Eigen::Vector3d& centre,
                     double& radius) {
  if (V.rows() == 0) {
    centre.setZero();
    radius = 1.0;
    return;
  }
  const Eigen::Vector3d lo = V.colwise().minCoeff().transpose();
  const Eigen::Vector3d hi = V.colwise().maxCoeff().transpose();
  centre = 0.5 * (lo + hi);
  radius = std::sqrt((V.rowwise() - centre.transpose()).rowwise().squaredNorm().maxCoeff());
  if (!(radius > 0.0)) radius = 1e-3;
}

double fit_distance(const Camera& cam, double radius, int width, int height) {
  const double aspect = static_cast<double>(std::max(width, 1)) / std::max(height, 1);
  const double fovy = cam.fov_y_deg * kPi / 180.0;
  const double half_min = std::atan(std::tan(fovy / 2) * std::min(aspect, 1.0));
  return radius / std::sin(half_min) / 0.9;
}

CameraMatrices camera_matrices(const Camera& cam, const Eigen::Vector3d& centre, double radius,
                               int width, int height) {
  CameraMatrices m;
  m.width = std::max(width, 1);
  m.height = std::max(height, 1);
  const double aspect = static_cast<double>(m.width) / m.height;
  const double fovy = cam.fov_y_deg * kPi / 180.0;
  m.target = cam.target.value_or(centre);
  m.distance = cam.distance > 0.0
                   ? cam.distance
                   : fit_distance(cam, radius + (m.target - centre).norm(), width, height);
  const double az = cam.azimuth_deg * kPi / 180.0, el = cam.elevation_deg * kPi / 180.0;
  const Eigen::Vector3d back(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                             std::sin(el));
  m.eye = m.target + m.distance * back;
  m.forward = -back;
  // Looking straight down or up, +z cannot be the up vector; +y is used instead.
  const Eigen::Vector3d up_hint =
      std::abs(back.z()) > 0.999 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d f = m.forward;
  const Eigen::Vector3d s = f.cross(up_hint).normalized();
  const Eigen::Vector3d u = s.cross(f);
  m.view.setIdentity();
  m.view.block<1, 3>(0, 0) = s.transpose();
  m.view.block<1, 3>(1, 0) = u.transpose();
  m.view.block<1, 3>(2, 0) = -f.transpose();
  m.view(0, 3) = -s.dot(m.eye);
  m.view(1, 3) = -u.dot(m.eye);
  m.view(2, 3) = f.dot(m.eye);
  // Depth range around the scene's bounding sphere (seen from the eye).
  const double reach = radius + (m.target - centre).norm();
  const double d_centre = (centre - m.eye).norm();
  const double znear = std::max(d_centre - 2.0 * reach, 1e-3 * d_centre);
  const double zfar = d_centre + 2.0 * reach;
  const double t = 1.0 / std::tan(fovy / 2);
  m.proj.setZero();
  m.proj(0, 0) = t / aspect;
  m.proj(1, 1) = t;
  m.proj(2, 2) = -(zfar + znear) / (zfar - znear);
  m.proj(2, 3) = -2.0 * zfar * znear / (zfar - znear);
  m.proj(3, 2) = -1.0;
  return m;
}

Eigen::Vector2d CameraMatrices::project(const Eigen::Vector3d& p, double* depth) const {
  const Eigen::Vector4d e = view * p.homogeneous();
  const Eigen::Vector4d c = proj * e;
  if (depth) *depth = -e.z();
  const double x = c.x() / c.w(), y = c.y() / c.w();
  return {(x + 1.0) * 0.5 * width, (1.0 - y) * 0.5 * height};
}

void CameraMatrices::unproject(double x, double y, Eigen::Vector3d& origin,
                               Eigen::Vector3d& dir) const {
  const double nx = 2.0 * x / width - 1.0, ny = 1.0 - 2.0 * y / height;
  const Eigen::Vector3d eye_dir(nx / proj(0, 0), ny / proj(1, 1), -1.0);
  const Eigen::Matrix3d r = view.block<3, 3>(0, 0);  // rows: s, u, -f
  origin = eye;
  dir = (r.transpose() * eye_dir).normalized();
}

}  // namespace palplab::render
