#include "render/pick.h"

#include <gtest/gtest.h>

#include <cmath>

namespace hapvox::render {
namespace {

// A half-space of density 1 for voxels x >= 4 in an 8^3 box of 1 x 2 x 1 mm voxels whose
// corner is at (10, 20, 30) mm: the trilinear density crosses 0.5 half way between the
// centres of voxels 3 and 4, at x = 10 + 4 mm.
DenseVolume half_space() {
  DenseVolume volume;
  volume.dims = Eigen::Vector3i(8, 8, 8);
  volume.voxel_mm = Eigen::Vector3d(1.0, 2.0, 1.0);
  volume.lo_mm = Eigen::Vector3d(10.0, 20.0, 30.0);
  volume.hi_mm = volume.lo_mm + volume.voxel_mm.cwiseProduct(Eigen::Vector3d(8, 8, 8));
  volume.density.assign(volume.voxel_count(), 0.0f);
  for (int z = 0; z < 8; ++z)
    for (int y = 0; y < 8; ++y)
      for (int x = 4; x < 8; ++x) volume.density[volume.index(x, y, z)] = 1.0f;
  return volume;
}

TEST(Pick, DensityIsTrilinearBetweenVoxelCentres) {
  const DenseVolume volume = half_space();
  EXPECT_DOUBLE_EQ(density_at(volume, Eigen::Vector3d(13.5, 25.0, 33.5)), 0.0);  // centre of 3
  EXPECT_DOUBLE_EQ(density_at(volume, Eigen::Vector3d(14.5, 25.0, 33.5)), 1.0);  // centre of 4
  EXPECT_DOUBLE_EQ(density_at(volume, Eigen::Vector3d(14.0, 25.0, 33.5)), 0.5);
  EXPECT_DOUBLE_EQ(density_at(volume, Eigen::Vector3d(13.75, 21.0, 31.0)), 0.25);
}

TEST(Pick, TheRayStopsWhereTheDensityCrossesTheThreshold) {
  const DenseVolume volume = half_space();
  // Along +x from outside the box: the half density is at x = 14 mm, the rest unchanged.
  const auto along_x =
      pick_surface(volume, Eigen::Vector3d(0.0, 27.3, 34.1), Eigen::Vector3d(1.0, 0.0, 0.0), 0.5);
  ASSERT_TRUE(along_x.has_value());
  EXPECT_NEAR(along_x->x(), 14.0, 1e-5);
  EXPECT_EQ(along_x->y(), 27.3);
  EXPECT_EQ(along_x->z(), 34.1);
  // A higher threshold lies deeper: 0.75 is three quarters of the way to voxel 4's centre.
  const auto deeper =
      pick_surface(volume, Eigen::Vector3d(0.0, 27.3, 34.1), Eigen::Vector3d(2.0, 0.0, 0.0), 0.75);
  ASSERT_TRUE(deeper.has_value());
  EXPECT_NEAR(deeper->x(), 14.25, 1e-5);
  // An oblique ray meets the plane x = 14 where the line does.
  const Eigen::Vector3d origin(11.0, 21.0, 31.0), direction(1.0, 1.0, 0.5);
  const auto oblique = pick_surface(volume, origin, direction, 0.5);
  ASSERT_TRUE(oblique.has_value());
  const Eigen::Vector3d expected = origin + 3.0 * direction;  // x: 11 + 3 = 14
  EXPECT_LT((*oblique - expected).norm(), 1e-5);
}

TEST(Pick, ARayIntoTheMaterialStopsAtTheBoxAndOneThatSeesNothingMisses) {
  const DenseVolume volume = half_space();
  // From beyond the +x face, looking back: the material starts at the face.
  const auto from_behind =
      pick_surface(volume, Eigen::Vector3d(30.0, 25.0, 33.0), Eigen::Vector3d(-1.0, 0.0, 0.0), 0.5);
  ASSERT_TRUE(from_behind.has_value());
  EXPECT_NEAR(from_behind->x(), 18.0, 1e-9);
  // Along the empty half only, and past the box altogether.
  EXPECT_FALSE(
      pick_surface(volume, Eigen::Vector3d(12.0, 0.0, 33.0), Eigen::Vector3d(0.0, 1.0, 0.0), 0.5));
  EXPECT_FALSE(
      pick_surface(volume, Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(-1.0, 0.0, 0.0), 0.5));
  EXPECT_FALSE(
      pick_surface(volume, Eigen::Vector3d(0.0, 25.0, 33.0), Eigen::Vector3d(0.0, 0.0, 0.0), 0.5));
}

TEST(Pick, TheNormalPointsOutOfTheMaterial) {
  const DenseVolume volume = half_space();
  // Material at x > 14 mm: out is -x, wherever the density changes.
  const Eigen::Vector3d at_surface = surface_normal(volume, Eigen::Vector3d(14.0, 27.3, 34.1));
  EXPECT_NEAR(at_surface.x(), -1.0, 1e-12);
  EXPECT_NEAR(at_surface.y(), 0.0, 1e-12);
  EXPECT_NEAR(at_surface.z(), 0.0, 1e-12);
  // Deep inside (flat density) there is no normal.
  EXPECT_EQ(surface_normal(volume, Eigen::Vector3d(16.5, 27.0, 34.0)), Eigen::Vector3d::Zero());
}

TEST(Pick, AHoveringToolBacksOffUntilNoPartOfItTouchesTheMaterial) {
  // From the half-space's surface (x = 14 mm) back along -x, a tool of radius 2 mm is clear
  // once its +x side is below the half density: at the first quarter-voxel step past x = 12.
  const DenseVolume volume = half_space();
  const Eigen::Vector3d off = clear_of_material(volume, Eigen::Vector3d(14.0, 27.0, 34.0),
                                                Eigen::Vector3d(-3.0, 0.0, 0.0), 2.0, 0.5, 10.0);
  EXPECT_EQ(off, Eigen::Vector3d(11.75, 27.0, 34.0));
  // Already clear: it stays; no direction: it stays; never clear within reach: the farthest.
  const Eigen::Vector3d free_point(11.0, 27.0, 34.0);
  EXPECT_EQ(clear_of_material(volume, free_point, Eigen::Vector3d(-1, 0, 0), 2.0, 0.5, 5.0),
            free_point);
  EXPECT_EQ(clear_of_material(volume, Eigen::Vector3d(16.0, 27.0, 34.0), Eigen::Vector3d::Zero(),
                              2.0, 0.5, 5.0),
            Eigen::Vector3d(16.0, 27.0, 34.0));
  EXPECT_EQ(clear_of_material(volume, Eigen::Vector3d(15.0, 27.0, 34.0), Eigen::Vector3d(1, 0, 0),
                              2.0, 0.5, 1.0),
            Eigen::Vector3d(16.0, 27.0, 34.0));

  // A slot 4 mm wide (x in [2, 6] mm) through a slab (z < 4 mm): a tool of radius 2.5 mm
  // does not fit, so from the slot's bottom it backs out to above the slab (its side samples
  // reach the walls until z passes 4 mm), not to a standoff from one wall.
  DenseVolume slab;
  slab.dims = Eigen::Vector3i(8, 8, 8);
  slab.voxel_mm = Eigen::Vector3d(1.0, 1.0, 1.0);
  slab.lo_mm = Eigen::Vector3d::Zero();
  slab.hi_mm = Eigen::Vector3d(8.0, 8.0, 8.0);
  slab.density.assign(slab.voxel_count(), 0.0f);
  for (int z = 0; z < 4; ++z)
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x)
        if (x < 2 || x >= 6) slab.density[slab.index(x, y, z)] = 1.0f;
  EXPECT_EQ(clear_of_material(slab, Eigen::Vector3d(4.0, 4.0, 1.0), Eigen::Vector3d(0, 0, 1), 2.5,
                              0.5, 10.0),
            Eigen::Vector3d(4.0, 4.0, 4.25));
  // A tool of radius 1.5 mm fits in the slot: it is clear where it starts.
  EXPECT_EQ(clear_of_material(slab, Eigen::Vector3d(4.0, 4.0, 1.0), Eigen::Vector3d(0, 0, 1), 1.5,
                              0.5, 10.0),
            Eigen::Vector3d(4.0, 4.0, 1.0));
}

}  // namespace
}  // namespace hapvox::render
