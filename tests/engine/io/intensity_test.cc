#include "engine/volume_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/io/intensity.h"
#include "engine/io/io_test_util.h"
#include "test_data.h"

namespace hapvox::engine {
namespace {

using namespace ::hapvox::engine::io_test;  // NOLINT(build/namespaces)

TEST(VolumeIoMapping, ThresholdWindowAndOtsu) {
  RawVolume raw;
  raw.dims = Vec3i(4, 2, 1);
  raw.intensity = {0, 10, 20, 30, 100, 110, 120, 130};
  raw.min_intensity = 0;
  raw.max_intensity = 130;
  raw.spacing_mm = Vec3d(2, 2, 2);

  const double t = otsu_threshold(raw);
  EXPECT_GT(t, 30.0);
  EXPECT_LE(t, 100.0);
  const DensityField automatic = map_to_density(raw, {}, "src");
  EXPECT_EQ(automatic.active_voxel_count(), 4u);
  EXPECT_DOUBLE_EQ(automatic.total_density(), 4.0);
  EXPECT_FALSE(automatic.grid().tree().isValueOn(openvdb::Coord(3, 0, 0)));
  EXPECT_TRUE(automatic.grid().tree().isValueOn(openvdb::Coord(0, 1, 0)));
  EXPECT_EQ(automatic.voxel_size_mm(), Vec3d(2, 2, 2));

  const DensityField threshold =
      map_to_density(raw, {IntensityMapping::Kind::kThreshold, 20.0, 0.0}, "src");
  EXPECT_EQ(threshold.active_voxel_count(), 6u);

  const DensityField window =
      map_to_density(raw, {IntensityMapping::Kind::kWindow, 10.0, 110.0}, "src");
  EXPECT_EQ(window.active_voxel_count(), 6u);  // everything above 10
  EXPECT_FLOAT_EQ(window.grid().tree().getValue(openvdb::Coord(1, 1, 0)), 1.0f);
  EXPECT_FLOAT_EQ(window.grid().tree().getValue(openvdb::Coord(0, 1, 0)), 0.9f);
  EXPECT_FLOAT_EQ(window.grid().tree().getValue(openvdb::Coord(2, 0, 0)), 0.1f);
  expect_densities_in_unit_range(window);
}

// The one check of --threshold and --window, which the command line and the API share.
TEST(VolumeIoMapping, ThresholdAndWindowMappingsAreCheckedAsTheirFlags) {
  const IntensityMapping t = io::threshold_mapping(-40.5);
  EXPECT_EQ(t.kind, IntensityMapping::Kind::kThreshold);
  EXPECT_EQ(t.low, -40.5);
  const IntensityMapping w = io::window_mapping(-100.0, 300.0);
  EXPECT_EQ(w.kind, IntensityMapping::Kind::kWindow);
  EXPECT_EQ(w.low, -100.0);
  EXPECT_EQ(w.high, 300.0);
  EXPECT_EQ(testing::input_error_of([] { io::threshold_mapping(std::nan("")); }),
            "--threshold: must be finite");
  EXPECT_EQ(testing::input_error_of([] { io::window_mapping(0.0, INFINITY); }),
            "--window: must be finite");
  EXPECT_EQ(testing::input_error_of([] { io::window_mapping(5.0, 5.0); }),
            "--window: HI must exceed LO");
  EXPECT_EQ(testing::input_error_of([] { io::window_mapping(5.0, 1.0); }),
            "--window: HI must exceed LO");
}

TEST(VolumeIoMapping, WindowHighMustExceedLow) {
  RawVolume raw;
  raw.dims = Vec3i(1, 1, 1);
  raw.intensity = {1.0f};
  expect_input_error(
      [&] {
        map_to_density(raw, {IntensityMapping::Kind::kWindow, 5.0, 5.0}, "ct.nrrd");
      },
      "ct.nrrd", "window high must exceed low");
  expect_input_error(
      [&] {
        map_to_density(raw, {IntensityMapping::Kind::kWindow, 5.0, 1.0}, "ct.nrrd");
      },
      "ct.nrrd", "window high must exceed low");
  // Through load_volume the file is named.
  const std::string path = scratch_dir() + "/w.nrrd";
  write_file(path, make_nrrd(basic_fields(), kEightBytes));
  expect_input_error(
      [&] {
        load_volume(path, {IntensityMapping::Kind::kWindow, 3.0, 2.0});
      },
      path, "window high must exceed low");
}

// ---- VDB -----------------------------------------------------------------------------

}  // namespace
}  // namespace hapvox::engine
