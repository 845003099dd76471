// Headerless raw volumes (engine/io/raw_file.h): the layout comes from the spec.

#include "engine/io/raw_file.h"

#include <cstdint>

#include "engine/io/formats.h"
#include "engine/io/io_test_util.h"
#include "engine/io/nrrd.h"

namespace hapvox::engine {
namespace {

using namespace io_test;  // NOLINT(build/namespaces)

// Big-endian int16 samples i + 10 j + 100 k - 150 (negative ones too) behind 5 junk bytes.
std::string write_int16_volume(const std::string& dir) {
  std::vector<std::int16_t> values;
  for (int k = 0; k < 2; ++k) {
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 4; ++i)
        values.push_back(static_cast<std::int16_t>(i + 10 * j + 100 * k - 150));
    }
  }
  write_file(dir + "/ct.raw", "JUNK!" + to_bytes(values, /*big_endian=*/true));
  return dir + "/ct.raw";
}

TEST(RawFile, ReadsTheLayoutTheSpecGives) {
  const std::string file = write_int16_volume(scratch_dir());
  const io::RawVolume raw = io::read_scalar_volume(
      file +
      ":dims=4x3x2,type=int16,endian=big,spacing_mm=0.5x2x3,origin_mm=-10x2.5x0,"
      "header_bytes=5");
  EXPECT_EQ(raw.dims, Vec3i(4, 3, 2));
  EXPECT_EQ(raw.sample_type, "int16");
  EXPECT_EQ(raw.spacing_mm, Vec3d(0.5, 2.0, 3.0));
  EXPECT_EQ(raw.origin_mm, Vec3d(-10.0, 2.5, 0.0));
  EXPECT_EQ(raw.direction, Mat3d::Identity());
  ASSERT_EQ(raw.intensity.size(), 24u);
  for (int k = 0; k < 2; ++k) {
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 4; ++i) {
        EXPECT_EQ(raw.intensity[static_cast<std::size_t>(i + 4 * (j + 3 * k))],
                  i + 10 * j + 100 * k - 150);
      }
    }
  }
  EXPECT_EQ(raw.min_intensity, -150.0);
  EXPECT_EQ(raw.max_intensity, -150.0 + 3 + 20 + 100);
}

TEST(RawFile, AgreesWithADetachedNrrdHeaderOverTheSameBytes) {
  const std::string dir = scratch_dir();
  const std::string file = write_int16_volume(dir);
  write_file(dir + "/ct.nhdr",
             "NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nspacings: 0.5 2 3\n"
             "endian: big\nencoding: raw\nbyte skip: 5\ndata file: ct.raw\n");
  const io::RawVolume nrrd = io::read_nrrd(dir + "/ct.nhdr");
  const io::RawVolume raw =
      io::read_raw_file(file +
                        ":dims=4x3x2,type=short,endian=big,spacing_mm=0.5x2x3,"
                        "header_bytes=5");
  EXPECT_EQ(raw.intensity, nrrd.intensity);
  EXPECT_EQ(raw.dims, nrrd.dims);
  EXPECT_EQ(raw.spacing_mm, nrrd.spacing_mm);
  // Read little endian (the default), every sample's bytes come out swapped.
  const io::RawVolume swapped = io::read_raw_file(file + ":dims=4x3x2,type=int16,header_bytes=5");
  EXPECT_EQ(swapped.intensity[0], static_cast<std::int16_t>(0x6aff));  // -150 is 0xff6a
  EXPECT_EQ(swapped.spacing_mm, Vec3d::Ones());
  EXPECT_EQ(swapped.origin_mm, Vec3d::Zero());
}

TEST(RawFile, LoadsAsADensityFieldWithItsGeometry) {
  const std::string dir = scratch_dir();
  write_file(dir + "/mask.RAW", std::string("\x00\x00\xff\xff\x00\xff\x00\xff", 8));
  const DensityField field = load_volume(dir + "/mask.RAW:dims=2x2x2,type=uint8,spacing_mm=2x2x2",
                                         {IntensityMapping::Kind::kThreshold, 128.0, 0.0});
  EXPECT_EQ(field.dims(), Vec3i(2, 2, 2));
  EXPECT_EQ(field.voxel_size_mm(), Vec3d::Constant(2.0));
  const auto density = [&](int i, int j, int k) {
    return field.grid().tree().getValue(openvdb::Coord(i, j, k));
  };
  EXPECT_EQ(density(0, 0, 0), 0.0f);
  EXPECT_EQ(density(0, 1, 0), 1.0f);
  EXPECT_EQ(density(1, 1, 1), 1.0f);
  EXPECT_EQ(density(0, 1, 1), 0.0f);
}

TEST(RawFile, BadSpecsAndFilesAreOneLineErrors) {
  const std::string dir = scratch_dir();
  const std::string file = write_int16_volume(dir);
  const std::string layout =
      "FILE.raw:dims=NXxNYxNZ,type=T[,endian=little|big][,spacing_mm=SXxSYxSZ]"
      "[,origin_mm=OXxOYxOZ][,header_bytes=N]";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "a raw file needs its layout: " + layout},
      {":type=int16", "dims= is missing: " + layout},
      {":dims=4x3x2", "type= is missing: " + layout},
      {":dims=4x3,type=int16", "dims=4x3: expected three finite numbers as AxBxC"},
      {":dims=4x0x2,type=int16", "dims=4x0x2: each size must be a whole number >= 1"},
      {":dims=4x3.5x2,type=int16", "dims=4x3.5x2: each size must be a whole number >= 1"},
      {":dims=2000x2000x2000,type=int16", "dims=2000x2000x2000: more than 2^31 samples"},
      {":dims=4x3x2,type=complex",
       "type=complex: unknown sample type (int8, uint8, int16, uint16, int32, uint32, int64, "
       "uint64, float or double)"},
      {":dims=4x3x2,type=int16,endian=middle", "endian=middle: expected little or big"},
      {":dims=4x3x2,type=int16,spacing_mm=1x0x1", "spacing_mm=1x0x1: spacings must be > 0"},
      {":dims=4x3x2,type=int16,origin_mm=1xnanx1",
       "origin_mm=1xnanx1: expected three finite numbers as AxBxC"},
      {":dims=4x3x2,type=int16,header_bytes=-1", "header_bytes=-1: expected a whole number >= 0"},
      {":dims=4x3x2,type=int16,dims=1x1x1", "option 'dims' given twice"},
      {":dims=4x3x2,type=int16,skew=1",
       "unknown option 'skew' (dims, type, endian, spacing_mm, origin_mm, header_bytes)"},
      {":dims=4x3x2,type=int16,big", "option 'big' is not key=value (" + layout + ")"},
  };
  for (const auto& [options, problem] : cases) {
    const std::string spec = file + options;
    EXPECT_EQ(testing::input_error_of([&] { io::read_scalar_volume(spec); }),
              spec + ": " + problem);
  }
  // The layout does not match the file: both sizes named, nothing allocated for the claim.
  EXPECT_EQ(testing::input_error_of(
                [&] { io::read_scalar_volume(file + ":dims=4x3x2,type=int16,endian=big"); }),
            file + ": holds 53 bytes, but 4x3x2 samples of int16 after 0 header bytes need 48");
  EXPECT_EQ(testing::input_error_of(
                [&] { io::read_scalar_volume(file + ":dims=4x3x2,type=float,header_bytes=5"); }),
            file + ": holds 53 bytes, but 4x3x2 samples of float after 5 header bytes need 101");
  EXPECT_EQ(testing::input_error_of(
                [&] { io::read_scalar_volume(dir + "/gone.raw:dims=1x1x1,type=uint8"); }),
            dir + "/gone.raw: cannot open the raw file");
}

TEST(RawFile, TheSpecNamesItsFileAsAnInput) {
  EXPECT_EQ(io::raw_data_file("a/ct.raw:dims=1x1x1,type=uint8"), "a/ct.raw");
  EXPECT_EQ(io::raw_data_file("a/ct.RAW"), "a/ct.RAW");
  EXPECT_EQ(io::raw_data_file("a/ct.nrrd"), "");
  const io::VolumeFormat* format = io::find_volume_format("a/ct.raw:dims=1x1x1,type=uint8");
  ASSERT_NE(format, nullptr);
  EXPECT_EQ(io::companion_input(*format, "a/ct.raw:dims=1x1x1,type=uint8"), "a/ct.raw");
  EXPECT_EQ(format->write, nullptr);  // hapvox reads raw files, never writes them
}

}  // namespace
}  // namespace hapvox::engine
