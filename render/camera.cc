#include "render/camera.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace hapvox::render {
namespace {
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
}

Eigen::Vector3d OrbitCamera::eye_mm() const {
  const double el = std::clamp(elevation_deg, -89.0, 89.0) * kDegToRad;
  const double az = azimuth_deg * kDegToRad;
  return target_mm + distance_mm * Eigen::Vector3d(std::cos(el) * std::cos(az),
                                                   std::cos(el) * std::sin(az), std::sin(el));
}

Eigen::Vector3d OrbitCamera::view_direction() const { return (target_mm - eye_mm()).normalized(); }

Eigen::Matrix4d OrbitCamera::view() const {
  const Eigen::Vector3d eye = eye_mm();
  const Eigen::Vector3d f = view_direction();
  const Eigen::Vector3d s = f.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d u = s.cross(f);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<1, 3>(0, 0) = s.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -s.dot(eye);
  m(1, 3) = -u.dot(eye);
  m(2, 3) = f.dot(eye);
  return m;
}

Eigen::Matrix4d OrbitCamera::projection(double aspect, double near_mm, double far_mm) const {
  const double t = 1.0 / std::tan(0.5 * fov_y_deg * kDegToRad);
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m(0, 0) = t / aspect;
  m(1, 1) = t;
  m(2, 2) = (far_mm + near_mm) / (near_mm - far_mm);
  m(2, 3) = 2.0 * far_mm * near_mm / (near_mm - far_mm);
  m(3, 2) = -1.0;
  return m;
}

Eigen::Vector3d OrbitCamera::pixel_ray(int x, int y, int width, int height) const {
  const Eigen::Vector3d f = view_direction();
  const Eigen::Vector3d s = f.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d u = s.cross(f);
  const double t = std::tan(0.5 * fov_y_deg * kDegToRad);
  const double aspect = static_cast<double>(width) / height;
  const double x_ndc = 2.0 * (x + 0.5) / width - 1.0;
  const double y_ndc = 1.0 - 2.0 * (y + 0.5) / height;  // row 0 at the top
  return (f + x_ndc * t * aspect * s + y_ndc * t * u).normalized();
}

OrbitCamera OrbitCamera::framing(const Eigen::Vector3d& lo_mm, const Eigen::Vector3d& hi_mm,
                                 double azimuth_deg, double elevation_deg) {
  OrbitCamera camera;
  camera.target_mm = 0.5 * (lo_mm + hi_mm);
  camera.azimuth_deg = azimuth_deg;
  camera.elevation_deg = elevation_deg;
  const double radius = 0.5 * (hi_mm - lo_mm).norm();
  // The bounding sphere fills the vertical field of view with a small margin.
  camera.distance_mm = 1.05 * radius / std::sin(0.5 * camera.fov_y_deg * kDegToRad);
  return camera;
}

}  // namespace hapvox::render
