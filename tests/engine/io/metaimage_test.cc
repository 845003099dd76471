#include "engine/io/metaimage.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/input_limits.h"
#include "engine/io/io_test_util.h"
#include "engine/volume_io.h"
#include "test_data.h"

namespace hapvox::engine {
namespace {

using ::hapvox::testing::scratch_dir;
using ::testing::HasSubstr;
using namespace ::hapvox::engine::io_test;  // NOLINT(build/namespaces)

// A rotation about (1, 2, 3) by 0.7 rad, then a mirror of y: an oblique, left-handed grid.
Mat3d oblique_direction() {
  Mat3d d = Eigen::AngleAxisd(0.7, Vec3d(1, 2, 3).normalized()).toRotationMatrix();
  d.col(1) = -d.col(1);
  return d;
}

// A MetaImage header as ITK writes one; `fields` replace or add lines ("Key = Value").
std::string mha_header(const std::vector<std::string>& fields) {
  std::vector<std::string> lines = {"ObjectType = Image",
                                    "NDims = 3",
                                    "BinaryData = True",
                                    "BinaryDataByteOrderMSB = False",
                                    "CompressedData = False",
                                    "TransformMatrix = 1 0 0 0 1 0 0 0 1",
                                    "Offset = 0 0 0",
                                    "CenterOfRotation = 0 0 0",
                                    "AnatomicalOrientation = RAI",
                                    "ElementSpacing = 1 1 1",
                                    "DimSize = 2 2 2",
                                    "ElementType = MET_UCHAR"};
  for (const std::string& f : fields) {
    const std::string key = f.substr(0, f.find(" ="));
    bool replaced = false;
    for (std::string& line : lines) {
      if (line.substr(0, line.find(" =")) == key) {
        line = f;
        replaced = true;
      }
    }
    if (!replaced) lines.push_back(f);
  }
  std::string text;
  for (const std::string& line : lines) {
    if (line.find("= ") + 2 != line.size()) text += line + "\n";  // "Key = " drops the field
  }
  return text;
}

std::string mha(const std::vector<std::string>& fields, const std::string& payload) {
  return mha_header(fields) + "ElementDataFile = LOCAL\n" + payload;
}

// scratch_dir() empties the test's folder: each test asks once and passes it on.
std::string write_mha(const std::string& dir, const std::string& name,
                      const std::string& contents) {
  const std::string path = dir + "/" + name;
  write_file(path, contents);
  return path;
}

void expect_mha_error(const std::string& dir, const std::string& name, const std::string& contents,
                      const std::string& problem) {
  const std::string path = write_mha(dir, name, contents);
  expect_input_error([&] { io::read_metaimage(path); }, path, problem);
}

DensityField oblique_test_field() {
  const DensityField plain = make_test_field();
  return DensityField(plain.grid().deepCopy(), plain.voxel_size_mm(), plain.origin_mm(),
                      plain.dims(), oblique_direction());
}

void expect_same_field(const DensityField& back, const DensityField& field) {
  EXPECT_EQ(back.dims(), field.dims());
  EXPECT_EQ(back.voxel_size_mm(), field.voxel_size_mm());
  EXPECT_EQ(back.origin_mm(), field.origin_mm());
  EXPECT_EQ(back.direction(), field.direction());
  EXPECT_EQ(back.active_voxel_count(), field.active_voxel_count());
  auto acc = back.grid().getConstAccessor();
  for (auto it = field.grid().cbeginValueOn(); it; ++it) {
    ASSERT_EQ(acc.getValue(it.getCoord()), *it) << it.getCoord();
  }
}

TEST(VolumeIoMetaImage, WriteReadRoundTripKeepsVoxelsAndOrientation) {
  const std::string dir = scratch_dir();
  const DensityField field = oblique_test_field();
  for (const std::string name : {"field.mha", "field.mhd", "FIELD.MHA"}) {
    const std::string path = dir + "/" + name;
    io::write_metaimage(field, path);
    EXPECT_FALSE(std::filesystem::exists(path + ".partial"));
    const io::RawVolume raw = io::read_metaimage(path);
    EXPECT_TRUE(raw.holds_density) << name;
    EXPECT_EQ(raw.direction, field.direction()) << name;
    // A density file reads back as density (no Otsu threshold), every voxel bit for bit.
    expect_same_field(load_volume(path, {}), field);
  }
  EXPECT_TRUE(std::filesystem::exists(dir + "/field.zraw"));
  EXPECT_EQ(io::metaimage_data_file(dir + "/field.mhd"), dir + "/field.zraw");
  EXPECT_EQ(io::metaimage_data_file(dir + "/field.mha"), "");
}

TEST(VolumeIoMetaImage, ReadsGeometryAsItkWritesIt) {
  const std::string dir = scratch_dir();
  // Int16, big-endian, an oblique TransformMatrix whose row i is index axis i's direction.
  const Mat3d d = oblique_direction();
  std::string matrix = "TransformMatrix =";
  for (int axis = 0; axis < 3; ++axis) {
    for (int c = 0; c < 3; ++c) matrix += " " + std::to_string(d(c, axis));
  }
  const std::vector<std::int16_t> values = {-1000, -5, 0, 7, 300, 1200, -32768, 32767,
                                            1,     2,  3, 4, 5,   6,    7,      8};
  const std::string path =
      write_mha(dir, "ct.mha",
                mha({matrix, "Offset = -12.5 30 7.25", "ElementSpacing = 0.5 0.75 2",
                     "DimSize = 2 4 2", "ElementType = MET_SHORT", "BinaryDataByteOrderMSB = True",
                     "AnatomicalOrientation = LPS"},
                    to_bytes(values, /*big_endian=*/true)));
  const io::RawVolume raw = io::read_metaimage(path);
  EXPECT_EQ(raw.dims, Vec3i(2, 4, 2));
  EXPECT_EQ(raw.spacing_mm, Vec3d(0.5, 0.75, 2.0));
  EXPECT_EQ(raw.origin_mm, Vec3d(-12.5, 30.0, 7.25));
  EXPECT_TRUE(raw.direction.isApprox(d, 1e-6)) << raw.direction;
  EXPECT_EQ(raw.sample_type, "int16");
  EXPECT_FALSE(raw.holds_density);
  ASSERT_EQ(raw.intensity.size(), values.size());
  for (std::size_t i = 0; i < values.size(); ++i) EXPECT_EQ(raw.intensity[i], values[i]) << i;
  // World position of voxel (1, 3, 1): offset + D (ijk * spacing).
  const DensityField field = load_volume(path, {io::IntensityMapping::Kind::kThreshold, -2000});
  const Vec3d expected = Vec3d(-12.5, 30.0, 7.25) + d * Vec3d(0.5, 2.25, 2.0);
  EXPECT_TRUE(field.index_to_world(Vec3d(1, 3, 1)).isApprox(expected, 1e-6));
  EXPECT_TRUE(field.world_to_index(expected).isApprox(Vec3d(1, 3, 1), 1e-6));
}

TEST(VolumeIoMetaImage, CompressedLocalAndDetachedData) {
  const std::string dir = scratch_dir();
  const std::vector<float> values = {0.0f, 0.25f, 0.5f, 1.0f, 2.0f, 3.0f, 4.0f, 5.0f};
  const std::string bytes = to_bytes(values, false);
  // CompressedData is zlib; a gzip stream is inflated too.
  const std::string z = zlib(bytes);
  const io::RawVolume local =
      io::read_metaimage(write_mha(dir, "z.mha",
                                   mha({"CompressedData = True", "ElementType = MET_FLOAT",
                                        "CompressedDataSize = " + std::to_string(z.size())},
                                       z)));
  EXPECT_EQ(local.intensity, values);

  // Detached: HeaderSize bytes skipped, or -1 for the data at the file's end.
  write_file(dir + "/d.raw", "JUNKHEADER" + bytes);
  const std::string skip = write_mha(
      dir, "d.mhd",
      mha_header({"ElementType = MET_FLOAT", "HeaderSize = 10"}) + "ElementDataFile = d.raw\n");
  EXPECT_EQ(io::read_metaimage(skip).intensity, values);
  const std::string tail = write_mha(
      dir, "t.mhd",
      mha_header({"ElementType = MET_FLOAT", "HeaderSize = -1"}) + "ElementDataFile = d.raw\n");
  EXPECT_EQ(io::read_metaimage(tail).intensity, values);
  EXPECT_EQ(io::metaimage_data_file(tail), dir + "/d.raw");
}

TEST(VolumeIoMetaImageErrors, EveryBadHeaderNamesTheProblem) {
  const std::string dir = scratch_dir();
  const std::string eight(8, '\1');
  expect_input_error([&] { io::read_metaimage(dir + "/none.mha"); }, dir + "/none.mha",
                     "cannot open file");
  expect_mha_error(dir, "binary.mha", std::string("\x89PNG\r\n\x1a\n\0\0", 10),
                   "not a MetaImage file");
  expect_mha_error(dir, "nodata.mha", mha_header({}), "no ElementDataFile line");
  expect_mha_error(dir, "ndims.mha", mha({"NDims = 2"}, eight), "NDims 2 is not supported");
  expect_mha_error(dir, "rgb.mha", mha({"ElementNumberOfChannels = 3"}, eight),
                   "ElementNumberOfChannels 3 is not supported");
  expect_mha_error(dir, "type.mha", mha({"ElementType = MET_STRING"}, eight),
                   "unsupported ElementType 'MET_STRING'");
  expect_mha_error(dir, "notype.mha", mha({"ElementType = "}, eight),
                   "missing required field 'ElementType'");
  expect_mha_error(dir, "ascii.mha", mha({"BinaryData = False"}, eight), "ASCII data");
  expect_mha_error(dir, "dims.mha", mha({"DimSize = 2 2"}, eight), "DimSize must list 3 positive");
  expect_mha_error(dir, "spacing.mha", mha({"ElementSpacing = 1 0 1"}, eight),
                   "ElementSpacing must be positive");
  expect_mha_error(dir, "nan.mha", mha({"Offset = 0 nan 0"}, eight), "Offset must list 3 finite");
  expect_mha_error(dir, "shear.mha", mha({"TransformMatrix = 1 0 0 0.5 1 0 0 0 1"}, eight),
                   "TransformMatrix is not orthonormal");
  expect_mha_error(dir, "orient.mha", mha({"AnatomicalOrientation = RLI"}, eight),
                   "AnatomicalOrientation 'RLI'");
  expect_mha_error(dir, "twice.mha", mha({"NDims = 3", "ndims = 3"}, eight), "appears twice");
  expect_mha_error(dir, "short.mha", mha({}, eight.substr(0, 5)),
                   "truncated data: expected 8 bytes, got 5");
  expect_mha_error(dir, "long.mha", mha({}, eight + "x"), "too much data");
  expect_mha_error(dir, "zlib.mha", mha({"CompressedData = True"}, "not zlib at all"),
                   "corrupt gzip data");
  expect_mha_error(dir, "list.mhd", mha_header({}) + "ElementDataFile = LIST 2D\n",
                   "multi-file data");
  expect_mha_error(dir, "missing.mhd", mha_header({}) + "ElementDataFile = gone.raw\n",
                   "cannot open data file");
  expect_mha_error(
      dir, "nanfloat.mha",
      mha({"ElementType = MET_FLOAT", "DimSize = 1 1 1"}, to_bytes(std::vector<float>{NAN}, false)),
      "NaN or infinite");
}

TEST(VolumeIoMetaImageErrors, AbsurdSizeIsRefusedBeforeAllocating) {
  const std::string dir = scratch_dir();
  // 2^51 samples: refused from the header alone (an allocation would throw bad_alloc or,
  // under ASan, abort), whatever the (tiny) payload.
  expect_mha_error(dir, "huge.mha", mha({"DimSize = 131072 131072 131072"}, "x"),
                   "DimSize '131072 131072 131072' is too large (over 2^31 samples)");
  const std::string big = mha({"DimSize = 2048 2048 511", "CompressedData = True"}, zlib("tiny"));
  expect_mha_error(dir, "big_z.mha", big,
                   "2048 x 2048 x 511 uint8 samples take 8176 MB decoded, over the limit of 2048 "
                   "MB (raise it with --max-input-mb)");
  InputLimits& limits = input_limits();  // raised: the payload ends short
  const InputLimits saved = limits;
  limits.max_input_mb = 8192;
  expect_mha_error(dir, "huge_z.mha", big, "truncated data");
  limits = saved;
}

}  // namespace
}  // namespace hapvox::engine
