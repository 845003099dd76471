// The orbit camera's pixel rays against its own projection: a world point projected to a
// pixel lies on the ray through that pixel's centre, up to the half pixel it was rounded by.

#include "render/camera.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

namespace hapvox::render {
namespace {

// The pixel (column, row from the top) where `camera` shows `point_mm`, and its depth.
Eigen::Vector2d project(const OrbitCamera& camera, const Eigen::Vector3d& point_mm, int width,
                        int height) {
  const Eigen::Vector4d clip = camera.projection(static_cast<double>(width) / height, 1.0, 1e4) *
                               camera.view() * point_mm.homogeneous();
  const Eigen::Vector2d ndc = clip.head<2>() / clip.w();
  return {0.5 * (ndc.x() + 1.0) * width, 0.5 * (1.0 - ndc.y()) * height};
}

TEST(OrbitCamera, APointLiesOnTheRayThroughThePixelItProjectsTo) {
  const OrbitCamera camera =
      OrbitCamera::framing(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(128, 96, 64), 30.0, 25.0);
  const int width = 640, height = 480;
  const double pixel_rad = 2.0 * std::tan(0.5 * camera.fov_y_deg * M_PI / 180.0) / height;
  for (const Eigen::Vector3d& point : {Eigen::Vector3d(64, 48, 32), Eigen::Vector3d(10, 90, 5),
                                       Eigen::Vector3d(120, 3, 60), Eigen::Vector3d(0, 0, 64)}) {
    const Eigen::Vector2d pixel = project(camera, point, width, height);
    const int x = static_cast<int>(std::floor(pixel.x()));
    const int y = static_cast<int>(std::floor(pixel.y()));
    ASSERT_TRUE(x >= 0 && x < width && y >= 0 && y < height) << pixel.transpose();
    const Eigen::Vector3d to_point = (point - camera.eye_mm()).normalized();
    const double angle =
        std::acos(std::min(1.0, camera.pixel_ray(x, y, width, height).dot(to_point)));
    // Within the pixel's diagonal (angles per pixel shrink off-axis, never grow past this).
    EXPECT_LE(angle, std::sqrt(0.5) * pixel_rad * 1.0001) << point.transpose();
    // The neighbour two pixels to the right is further off: the ray is not just "forward".
    const double off = std::acos(camera.pixel_ray(x + 2, y, width, height).dot(to_point));
    EXPECT_GT(off, 1.4 * pixel_rad) << point.transpose();
  }
  // The target sits between the four centre pixels.
  const Eigen::Vector3d centre =
      (camera.pixel_ray(319, 239, width, height) + camera.pixel_ray(320, 240, width, height))
          .normalized();
  EXPECT_NEAR(centre.dot(camera.view_direction()), 1.0, 1e-12);
}

}  // namespace
}  // namespace hapvox::render
