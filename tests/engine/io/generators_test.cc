#include "engine/volume_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "engine/errors.h"
#include "engine/io/io_test_util.h"
#include "test_data.h"

namespace hapvox::engine {
namespace {

using namespace ::hapvox::engine::io_test;  // NOLINT(build/namespaces)

TEST(VolumeIoGenerators, BlockMassIsVoxelCount) {
  const DensityField block = generate_volume("block:dims=16,voxel_mm=0.5,fill=0.25");
  EXPECT_EQ(block.dims(), Vec3i(16, 16, 16));
  EXPECT_EQ(block.voxel_size_mm(), Vec3d::Constant(0.5));
  EXPECT_EQ(block.origin_mm(), Vec3d::Zero());  // voxel 0's centre at the origin
  EXPECT_EQ(block.active_voxel_count(), 16u * 16u * 4u);
  EXPECT_DOUBLE_EQ(block.total_density(), 16.0 * 16.0 * 4.0);
  EXPECT_EQ(block.grid().tree().activeTileCount(), 0u);  // leaves, not tiles
  EXPECT_TRUE(block.grid().tree().isValueOn(openvdb::Coord(15, 15, 3)));
  EXPECT_FALSE(block.grid().tree().isValueOn(openvdb::Coord(0, 0, 4)));

  const DensityField by_default = generate_volume("block");
  EXPECT_EQ(by_default.dims(), Vec3i(128, 128, 128));
  EXPECT_EQ(by_default.active_voxel_count(), 128u * 128u * 64u);
  EXPECT_EQ(by_default.grid().tree().activeTileCount(), 0u);

  EXPECT_EQ(generate_volume("block:dims=10,fill=0.3").active_voxel_count(), 300u);
  EXPECT_EQ(generate_volume("block:dims=10,fill=0").active_voxel_count(), 0u);
}

// The partial-volume sphere holds 4/3 pi r^3 of material to 0.01 % (its edge voxels hold
// their share; measured +0.0005 %); the binary one only to its staircase's 2 %.
TEST(VolumeIoGenerators, SphereMassMatchesVolume) {
  const double expected = 4.0 / 3.0 * std::numbers::pi * std::pow(10.0 / 0.5, 3);
  const DensityField sphere = generate_volume("sphere:dims=64,voxel_mm=0.5,radius_mm=10");
  EXPECT_NEAR(sphere.total_density(), expected, 1e-4 * expected);
  expect_densities_in_unit_range(sphere);
  std::size_t partial = 0;
  for (auto it = sphere.grid().cbeginValueOn(); it; ++it) partial += *it < 1.0f;
  EXPECT_GT(partial, 1000u);  // the edge: ~ 4 pi r^2 voxels
  // Centred on the box centre (31.5 per axis): the column of voxels (31, 31, z), spanning
  // x, y in [-1, 0] about it, holds their mean chord 2 sqrt(r^2 - x^2 - y^2) ~ 2r - (2/3)/r.
  const auto& tree = sphere.grid().tree();
  double column = 0.0;
  for (int z = 0; z < 64; ++z) column += tree.getValue(openvdb::Coord(31, 31, z));
  EXPECT_NEAR(column, 40.0 - 2.0 / 3.0 / 20.0, 2e-3);
  EXPECT_FLOAT_EQ(tree.getValue(openvdb::Coord(31, 31, 31 - 18)), 1.0f);
  EXPECT_FLOAT_EQ(tree.getValue(openvdb::Coord(31, 31, 32 + 18)), 1.0f);
  EXPECT_FALSE(tree.isValueOn(openvdb::Coord(0, 0, 0)));

  const DensityField binary =
      generate_volume("sphere:dims=64,voxel_mm=0.5,radius_mm=10,edge=binary");
  std::size_t whole = 0;
  for (auto it = binary.grid().cbeginValueOn(); it; ++it) whole += *it == 1.0f;
  EXPECT_EQ(whole, binary.active_voxel_count());
  EXPECT_NEAR(binary.total_density(), expected, 0.02 * expected);

  const DensityField by_default = generate_volume("sphere:dims=40");
  const double r = 0.35 * 40;
  const double expected_default = 4.0 / 3.0 * std::numbers::pi * r * r * r;
  EXPECT_NEAR(by_default.total_density(), expected_default, 1e-4 * expected_default);
}

TEST(VolumeIoGenerators, FourSpheresHaveFourDensities) {
  const DensityField phantom = generate_volume("four-spheres:dims=64");
  std::map<float, std::size_t> counts;
  for (auto it = phantom.grid().cbeginValueOn(); it; ++it) ++counts[*it];
  ASSERT_EQ(counts.size(), 4u);
  const std::vector<float> expected_densities = {0.4f, 0.6f, 0.8f, 1.0f};
  const double r = 0.18 * 64;
  const double sphere_voxels = 4.0 / 3.0 * std::numbers::pi * r * r * r;
  for (float d : expected_densities) {
    ASSERT_EQ(counts.count(d), 1u) << d;
    // Each sphere whole (inside the box, not overlapping another).
    EXPECT_NEAR(static_cast<double>(counts[d]), sphere_voxels, 0.03 * sphere_voxels) << d;
  }
  EXPECT_EQ(generate_volume("four-spheres").dims(), Vec3i(128, 128, 128));
}

TEST(VolumeIoGenerators, BadSpecs) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"cube", "unknown generator 'cube'"},
      {"block:dims=0", "dims must be an integer"},
      {"block:dims=abc", "dims must be an integer"},
      {"block:dims=2.5", "dims must be an integer"},
      {"block:dims", "expected key=value"},
      {"block:", "expected key=value"},
      {"block:color=red", "unknown option 'color'"},
      {"sphere:fill=0.5", "unknown option 'fill'"},
      {"sphere:edge=soft", "edge must be partial or binary, got 'soft'"},
      {"block:edge=binary", "unknown option 'edge'"},
      {"four-spheres:radius_mm=3", "unknown option 'radius_mm'"},
      {"block:fill=2", "fill must lie in [0, 1]"},
      {"sphere:radius_mm=-1", "radius_mm must be positive"},
      {"sphere:voxel_mm=0", "voxel_mm must be positive"},
      {"sphere:voxel_mm=inf", "voxel_mm must be a number"},
      {"block:dims=4,dims=5", "given twice"},
  };
  for (const auto& [spec, problem] : cases) {
    SCOPED_TRACE(spec);
    expect_input_error([&] { generate_volume(spec); }, "generator " + spec, problem);
  }
  // Through load_volume, a bad option of a known generator still names the generator.
  expect_input_error([&] { load_volume("sphere:dims=-3", {}); }, "generator sphere:dims=-3",
                     "dims must be an integer");
}

TEST(VolumeIoGenerators, IsGeneratorSpec) {
  EXPECT_TRUE(is_generator_spec("block"));
  EXPECT_TRUE(is_generator_spec("sphere:dims=8"));
  EXPECT_TRUE(is_generator_spec("four-spheres:voxel_mm=0.5"));
  EXPECT_FALSE(is_generator_spec("blocks"));
  EXPECT_FALSE(is_generator_spec("block.nrrd"));
  EXPECT_FALSE(is_generator_spec("data/sphere.vdb"));
  EXPECT_FALSE(is_generator_spec(""));

  // An existing file of that name wins over the generator.
  const auto old_cwd = std::filesystem::current_path();
  std::filesystem::current_path(scratch_dir());
  write_file("sphere", "x");
  const bool is_generator = is_generator_spec("sphere");
  std::filesystem::current_path(old_cwd);
  EXPECT_FALSE(is_generator);
}

// ---- load_volume dispatch ------------------------------------------------------------

}  // namespace
}  // namespace hapvox::engine
