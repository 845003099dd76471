// The voxel model's volume from labels and a materials file (engine/labels/tissue.h).
#include "engine/labels/tissue.h"

#include <gtest/gtest.h>

#include <string>

#include "engine/errors.h"
#include "test_data.h"

namespace hapvox::engine::labels {
namespace {

using ::hapvox::testing::input_error_of;

const char kSlab[] = R"(
[[material]]
label = 1
name = "fat"
youngs_modulus_pa = 20e3
poisson_ratio = 0.45
density = 0.8

[[material]]
label = 2
name = "bone"
youngs_modulus_pa = 5e9
poisson_ratio = 0.3
yield_stress_pa = 50e6
)";

// 8 x 4 x 4 voxels of 0.5 mm from (10, 20, 30): x < 3 label 1, x in [3, 6) label 2, the
// rest background (label 0).
LabelMap slab_labels() {
  LabelMap map(Vec3i(8, 4, 4), Vec3d::Constant(0.5), Vec3d(10, 20, 30));
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 8; ++i) map.set(Vec3i(i, j, k), i < 3 ? 1 : (i < 6 ? 2 : 0));
  return map;
}

TEST(TissueVolume, EachVoxelTakesItsLabelsDensityAndMaterial) {
  initialize_openvdb();
  const Materials materials = parse_materials(kSlab, "slab.toml");
  const TissueMaterial fallback{"command", {100e3, 0.3}, 7e3};
  const TissueVolume volume = tissue_volume(slab_labels(), materials, fallback);
  EXPECT_EQ(volume.field.dims(), Vec3i(8, 4, 4));
  EXPECT_EQ(volume.field.voxel_size_mm(), Vec3d::Constant(0.5));
  EXPECT_EQ(volume.field.origin_mm(), Vec3d(10, 20, 30));
  const auto density = volume.field.grid().getConstAccessor();
  for (int i = 0; i < 8; ++i) {
    const openvdb::Coord ijk(i, 2, 1);
    EXPECT_EQ(density.getValue(ijk), i < 3 ? 0.8f : (i < 6 ? 1.0f : 0.0f)) << i;
    EXPECT_EQ(volume.tissue.slot_at(ijk), i < 3 ? 1 : (i < 6 ? 2 : 0)) << i;
  }
  const auto& rows = volume.tissue.materials();
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].name, "command");
  EXPECT_EQ(rows[1].name, "fat");
  EXPECT_EQ(rows[1].elastic.youngs_modulus_pa, 20e3);
  EXPECT_EQ(rows[1].yield_stress_pa, 7e3);  // the command's: the file gives none
  EXPECT_EQ(rows[2].elastic.poisson_ratio, 0.3);
  EXPECT_EQ(rows[2].yield_stress_pa, 50e6);
  // The mass is the labels' densities: 3 x 16 fat voxels at 0.8, 3 x 16 bone voxels at 1.
  double mass = 0.0;
  for (auto it = volume.field.grid().cbeginValueOn(); it; ++it) mass += *it;
  EXPECT_DOUBLE_EQ(mass, 48 * double(0.8f) + 48 * 1.0);  // float densities
}

TEST(TissueVolume, ABackgroundMaterialWithADensityFillsTheBackground) {
  initialize_openvdb();
  const Materials materials = parse_materials(
      std::string(kSlab) +
          "[[material]]\nlabel = 0\nyoungs_modulus_pa = 1e3\npoisson_ratio = 0.2\ndensity = 0.25\n",
      "slab.toml");
  const TissueVolume volume = tissue_volume(slab_labels(), materials, {"", {1e5, 0.3}, 1e4});
  EXPECT_EQ(volume.field.grid().getConstAccessor().getValue({7, 0, 0}), 0.25f);
  EXPECT_EQ(volume.tissue.slot_at({7, 0, 0}), 3);
}

TEST(TissueVolume, ALabelWithoutAMaterialIsNamed) {
  initialize_openvdb();
  const Materials only_fat = parse_materials(
      "[[material]]\nlabel = 1\nyoungs_modulus_pa = 1e4\npoisson_ratio = 0.4\n", "fat.toml");
  EXPECT_EQ(input_error_of([&] {
              tissue_volume(slab_labels(), only_fat, {"", {1e5, 0.3}, 1e4});
            }),
            "fat.toml: label 2 has no material (48 voxels)");
}

}  // namespace
}  // namespace hapvox::engine::labels
