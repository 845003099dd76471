#include "engine/volume_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/io/io_test_util.h"
#include "test_data.h"

namespace hapvox::engine {
namespace {

using ::hapvox::testing::source_path;
using namespace ::hapvox::engine::io_test;  // NOLINT(build/namespaces)

// ---- real data -----------------------------------------------------------------------

TEST(VolumeIoRealData, EngineBlockLoads) {
  const std::string path = source_path("data/engine_256x256x128_uint8.nrrd");
  const RawVolume raw = read_nrrd(path);
  EXPECT_EQ(raw.dims, Vec3i(256, 256, 128));
  EXPECT_EQ(raw.spacing_mm, Vec3d(1, 1, 1));
  EXPECT_EQ(raw.origin_mm, Vec3d::Zero());
  EXPECT_EQ(raw.sample_type, "uint8");
  ASSERT_EQ(raw.intensity.size(), 256u * 256u * 128u);
  EXPECT_EQ(raw.min_intensity, 0.0);
  EXPECT_EQ(raw.max_intensity, 255.0);
  EXPECT_LT(raw.intensity[0], 16.0f);  // corner is air

  // Air sits below 16, the metal around 128..160: Otsu must split them.
  const double t = otsu_threshold(raw);
  EXPECT_GT(t, 16.0);
  EXPECT_LT(t, 128.0);

  const DensityField field = map_to_density(raw, IntensityMapping{}, path);
  EXPECT_EQ(field.dims(), raw.dims);
  EXPECT_EQ(field.voxel_size_mm(), raw.spacing_mm);
  expect_densities_in_unit_range(field);
  EXPECT_FALSE(field.grid().tree().isValueOn(openvdb::Coord(0, 0, 0)));
  EXPECT_EQ(field.active_voxel_count(), count_at_least(raw, t));
  EXPECT_GT(field.active_voxel_count(), 100000u);
}

TEST(VolumeIoRealData, HeadsqLoads) {
  const std::string path = source_path("data/headsq_64x64x93_uint16.nrrd");
  const RawVolume raw = read_nrrd(path);
  EXPECT_EQ(raw.dims, Vec3i(64, 64, 93));
  EXPECT_EQ(raw.spacing_mm, Vec3d(3.2, 3.2, 1.5));
  EXPECT_EQ(raw.sample_type, "uint16");
  ASSERT_EQ(raw.intensity.size(), 64u * 64u * 93u);
  EXPECT_GE(raw.min_intensity, 0.0);
  EXPECT_LT(raw.intensity[0], 200.0f);   // air ~0
  EXPECT_GT(raw.max_intensity, 1150.0);  // bone
  EXPECT_LT(raw.max_intensity, 32768.0);
  // Skin (~500) and bone (~1150) are both present, bone being the rarer.
  const std::size_t skin = count_at_least(raw, 500.0);
  const std::size_t bone = count_at_least(raw, 1150.0);
  EXPECT_GT(bone, 1000u);
  EXPECT_GT(skin, bone);

  const double t = otsu_threshold(raw);
  EXPECT_GT(t, 200.0);
  EXPECT_LT(t, 1000.0);

  const DensityField bone_field =
      map_to_density(raw, {IntensityMapping::Kind::kThreshold, 1150.0, 0.0}, path);
  EXPECT_EQ(bone_field.active_voxel_count(), bone);
  expect_densities_in_unit_range(bone_field);

  const DensityField window =
      map_to_density(raw, {IntensityMapping::Kind::kWindow, 0.0, 1150.0}, path);
  expect_densities_in_unit_range(window);
  EXPECT_EQ(window.voxel_size_mm(), Vec3d(3.2, 3.2, 1.5));
  bool fractional = false;
  for (auto it = window.grid().cbeginValueOn(); it && !fractional; ++it) fractional = *it < 0.9f;
  EXPECT_TRUE(fractional);
  EXPECT_EQ(window.active_voxel_count(), count_at_least(raw, 1e-3));
}

TEST(VolumeIoLoad, DispatchesByExtensionAndRejectsUnknown) {
  const DensityField gen = load_volume("block:dims=8", {});
  EXPECT_EQ(gen.active_voxel_count(), 8u * 8u * 4u);

  const std::string dir = scratch_dir();
  write_file(dir + "/v.NRRD", make_nrrd(basic_fields(), kEightBytes));
  EXPECT_EQ(load_volume(dir + "/v.NRRD", {IntensityMapping::Kind::kThreshold, 5.0, 0.0})
                .active_voxel_count(),
            4u);

  write_file(dir + "/v.bin", kEightBytes);
  const std::string problem =
      "unknown volume format (expected .nrrd, .nhdr, .vdb, .mha, .mhd, .nii, .nii.gz, .hdr, "
      ".dcm or .raw, a folder of DICOM slices, or a generator";
  expect_input_error([&] { load_volume(dir + "/v.bin", {}); }, dir + "/v.bin", problem);
  expect_input_error([&] { load_volume(dir + "/missing.tiff", {}); }, dir + "/missing.tiff",
                     problem);
  expect_input_error([&] { load_volume("cube:dims=3", {}); }, "cube:dims=3", problem);
}

TEST(VolumeIoFormats, EveryWriterRoundTripsVoxelsAndGeometry) {
  // A sculpted-looking field: partial densities, one above 1 (compressed clay), turned.
  const DensityField plain = make_test_field();
  plain.grid_ptr()->tree().setValueOn(openvdb::Coord(1, 1, 1), 1.75f);
  const Mat3d turn = Eigen::AngleAxisd(2.0, Vec3d(-1, 2, 0.5).normalized()).toRotationMatrix();
  const DensityField field(plain.grid().deepCopy(), plain.voxel_size_mm(), plain.origin_mm(),
                           plain.dims(), turn);
  int writers = 0;
  for (const io::VolumeFormat& format : io::volume_formats()) {
    if (format.write == nullptr) continue;
    ++writers;
    std::string ext = format.extensions.front();
    if (ext == ".nii") ext = ".nii.gz";
    const std::string path = scratch_dir() + "/every" + ext;
    format.write(field, path);
    // Default mapping (Otsu): a density file must not be thresholded.
    const DensityField back = load_volume(path, {});
    // NIfTI-1 stores its affine as 32-bit floats; the others as written, to the last bit.
    const double tol = format.name == std::string("NIfTI") ? 1e-6 : 1e-14;
    EXPECT_EQ(back.dims(), field.dims()) << format.name;
    EXPECT_TRUE(back.voxel_size_mm().isApprox(field.voxel_size_mm(), tol)) << format.name;
    EXPECT_TRUE(back.origin_mm().isApprox(field.origin_mm(), tol)) << format.name;
    EXPECT_TRUE(back.direction().isApprox(field.direction(), tol)) << format.name;
    EXPECT_EQ(back.total_density(), field.total_density()) << format.name;
    EXPECT_EQ(back.active_voxel_count(), field.active_voxel_count()) << format.name;
    auto acc = back.grid().getConstAccessor();
    for (auto it = field.grid().cbeginValueOn(); it; ++it) {
      ASSERT_EQ(acc.getValue(it.getCoord()), *it) << format.name << " " << it.getCoord();
    }
  }
  EXPECT_EQ(writers, 4);
}

TEST(VolumeIoFormats, ExtensionsMatchInAnyCase) {
  EXPECT_STREQ(io::find_volume_format("a/B.NRRD")->name, "NRRD");
  EXPECT_STREQ(io::find_volume_format("scan.Nii.Gz")->name, "NIfTI");
  EXPECT_STREQ(io::find_volume_format("x.MHD")->name, "MetaImage");
  EXPECT_EQ(io::find_volume_format("dir/.nrrd"), nullptr);
  EXPECT_EQ(io::find_volume_format("scan.gz"), nullptr);
  // A raw file's layout follows its name.
  EXPECT_STREQ(io::find_volume_format("ct.RAW:dims=2x2x2,type=uint8")->name, "raw");
  EXPECT_STREQ(io::find_volume_format("ct.raw")->name, "raw");
  EXPECT_EQ(io::find_volume_format("dir/.raw:dims=2x2x2"), nullptr);
  EXPECT_EQ(io::find_volume_format("ct.rawx:dims=2x2x2"), nullptr);
  EXPECT_EQ(io::volume_extensions_text(", ", " or "),
            ".nrrd, .nhdr, .vdb, .mha, .mhd, .nii, .nii.gz, .hdr, .dcm or .raw");
  EXPECT_EQ(io::volume_extensions_text(", ", " or ", /*written=*/true),
            ".nrrd, .nhdr, .vdb, .mha, .mhd, .nii or .nii.gz");
}

}  // namespace
}  // namespace hapvox::engine
