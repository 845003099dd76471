#pragma once
// An orbit camera around a target point, z up, perspective projection. Units: mm, degrees.

#include <Eigen/Core>

namespace hapvox::render {

struct OrbitCamera {
  Eigen::Vector3d target_mm = Eigen::Vector3d::Zero();
  double distance_mm = 500.0;
  double azimuth_deg = 30.0;    // around +z, from +x towards +y
  double elevation_deg = 25.0;  // above the xy plane, clamped to (-89, 89)
  double fov_y_deg = 35.0;

  Eigen::Vector3d eye_mm() const;
  /// Unit vector from the eye to the target.
  Eigen::Vector3d view_direction() const;
  /// World -> eye (OpenGL convention: the camera looks down -z).
  Eigen::Matrix4d view() const;
  /// Eye -> clip for an aspect ratio width / height; near and far planes in mm.
  Eigen::Matrix4d projection(double aspect, double near_mm, double far_mm) const;
  /// Unit vector from the eye through the centre of pixel (x, y) of a width x height image
  /// (row 0 at the top, as the PNGs hapvox writes): the ray picking follows (paper §3.2).
  Eigen::Vector3d pixel_ray(int x, int y, int width, int height) const;

  /// A camera that sees the whole box [lo, hi] from this camera's angles.
  static OrbitCamera framing(const Eigen::Vector3d& lo_mm, const Eigen::Vector3d& hi_mm,
                             double azimuth_deg, double elevation_deg);
};

}  // namespace hapvox::render
