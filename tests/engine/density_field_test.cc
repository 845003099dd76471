#include "engine/density_field.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

namespace hapvox::engine {
namespace {

DensityField turned_field(const Mat3d& direction) {
  initialize_openvdb();
  auto grid = openvdb::FloatGrid::create(0.0f);
  grid->tree().setValueOn(openvdb::Coord(1, 0, 0), 1.0f);
  return DensityField(grid, Vec3d(2.0, 1.0, 0.5), Vec3d(10, 20, 30), Vec3i(4, 2, 1), direction);
}

TEST(DensityField, IndexAndWorldAreInverseOnATurnedGrid) {
  const Mat3d turn = Eigen::AngleAxisd(0.8, Vec3d(1, -2, 0.5).normalized()).toRotationMatrix();
  const DensityField field = turned_field(turn);
  EXPECT_FALSE(field.axis_aligned());
  const Vec3d ijk(1.5, -0.25, 3.0);
  const Vec3d p = field.index_to_world(ijk);
  EXPECT_TRUE(p.isApprox(Vec3d(10, 20, 30) + turn * Vec3d(3.0, -0.25, 1.5), 1e-12));
  EXPECT_TRUE(field.world_to_index(p).isApprox(ijk, 1e-12));
  // The grid frame: the world turned back onto the index axes about the origin.
  EXPECT_TRUE(field.world_to_grid(p).isApprox(Vec3d(10, 20, 30) + Vec3d(3.0, -0.25, 1.5), 1e-12));
  EXPECT_TRUE(field.grid_to_world(field.world_to_grid(p)).isApprox(p, 1e-12));
  // Sampling follows the voxel wherever the grid is turned.
  EXPECT_NEAR(field.sample_world(field.index_to_world(Vec3d(1, 0, 0))), 1.0, 1e-12);
  EXPECT_NEAR(field.sample_world(field.index_to_world(Vec3d(1.5, 0, 0))), 0.5, 1e-12);
}

TEST(DensityField, WorldBoxBoundsTheTurnedCorners) {
  // 90 degrees about z: index x runs along world +y, index y along world -x.
  Mat3d quarter;
  quarter << 0, -1, 0,  //
      1, 0, 0,          //
      0, 0, 1;
  const DensityField field = turned_field(quarter);
  // Index box [-0.5, 3.5] x [-0.5, 1.5] x [-0.5, 0.5] scaled (2, 1, 0.5): x in [-1, 7],
  // y in [-0.5, 1.5], z in [-0.25, 0.25] in the grid frame.
  EXPECT_TRUE(field.world_min_mm().isApprox(Vec3d(10 - 1.5, 20 - 1, 30 - 0.25), 1e-12))
      << field.world_min_mm().transpose();
  EXPECT_TRUE(field.world_max_mm().isApprox(Vec3d(10 + 0.5, 20 + 7, 30 + 0.25), 1e-12))
      << field.world_max_mm().transpose();
  EXPECT_TRUE(field.grid_min_mm().isApprox(Vec3d(9, 19.5, 29.75), 1e-12));
  EXPECT_TRUE(field.grid_max_mm().isApprox(Vec3d(17, 21.5, 30.25), 1e-12));
  // Axis-aligned: the world box is the grid box.
  const DensityField plain = turned_field(Mat3d::Identity());
  EXPECT_TRUE(plain.axis_aligned());
  EXPECT_EQ(plain.world_min_mm(), plain.grid_min_mm());
  EXPECT_EQ(plain.world_max_mm(), plain.grid_max_mm());
}

}  // namespace
}  // namespace hapvox::engine
