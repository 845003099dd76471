#include "engine/volume_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/input_limits.h"
#include "engine/io/io_test_util.h"
#include "test_data.h"

namespace hapvox::engine {
namespace {

using namespace ::hapvox::engine::io_test;  // NOLINT(build/namespaces)

// ---- NRRD round trips and variants --------------------------------------------------

TEST(VolumeIoNrrd, WriteReadRoundTrip) {
  const DensityField field = make_test_field();
  const std::string path = scratch_dir() + "/field.nrrd";
  write_nrrd(field, path);
  EXPECT_FALSE(std::filesystem::exists(path + ".partial"));
  const std::string text = read_file(path);
  EXPECT_EQ(text.rfind("NRRD0004\n", 0), 0u);
  EXPECT_THAT(text, HasSubstr("\ntype: float\n"));
  EXPECT_THAT(text, HasSubstr("\nencoding: gzip\n"));
  EXPECT_THAT(text, HasSubstr("\nspace origin: (-3,2,7.5)\n"));

  const RawVolume raw = read_nrrd(path);
  EXPECT_EQ(raw.dims, field.dims());
  EXPECT_EQ(raw.spacing_mm, field.voxel_size_mm());
  EXPECT_EQ(raw.origin_mm, field.origin_mm());
  EXPECT_EQ(raw.sample_type, "float");
  auto acc = field.grid().getConstAccessor();
  std::size_t i = 0;
  for (int z = 0; z < 7; ++z) {
    for (int y = 0; y < 6; ++y) {
      for (int x = 0; x < 5; ++x, ++i) {
        ASSERT_EQ(raw.intensity[i], acc.getValue(openvdb::Coord(x, y, z))) << x << y << z;
      }
    }
  }
  // Back to a field through a unit window: same voxels.
  const DensityField again = load_volume(path, {IntensityMapping::Kind::kWindow, 0.0, 1.0});
  EXPECT_EQ(again.active_voxel_count(), field.active_voxel_count());
  EXPECT_DOUBLE_EQ(again.total_density(), field.total_density());
  EXPECT_EQ(again.origin_mm(), field.origin_mm());
}

TEST(VolumeIoNrrd, DetachedBigEndianInt16WithByteSkip) {
  const std::string dir = scratch_dir();
  const std::vector<std::int16_t> values = {-300, 0, 1, 2,  32767, -32768, 500, -1,
                                            7,    8, 9, 10, 11,    12,     13,  14};
  write_file(dir + "/vol.raw", "JUNK!" + to_bytes(values, /*big_endian=*/true));
  write_file(dir + "/vol.nhdr",
             "NRRD0005\n# detached\ntype: short\ndimension: 3\nsizes: 4 2 2\n"
             "space: right-anterior-superior\n"
             "space directions: (0.5,0,0) (0,-2,0) (0,0,3)\n"
             "space origin: (1,2.5,-3)\nkinds: domain domain domain\nendian: big\n"
             "encoding: raw\nbyte skip: 5\ndata file: vol.raw\nthe key:=with value\n");
  const RawVolume raw = read_nrrd(dir + "/vol.nhdr");
  EXPECT_EQ(raw.dims, Vec3i(4, 2, 2));
  EXPECT_EQ(raw.sample_type, "int16");
  EXPECT_EQ(raw.spacing_mm, Vec3d(0.5, 2.0, 3.0));
  // RAS into LPS: x and y negated, the unit vectors kept as the direction.
  EXPECT_EQ(raw.origin_mm, Vec3d(-1.0, -2.5, -3.0));
  EXPECT_EQ(raw.direction, Vec3d(-1, 1, 1).asDiagonal().toDenseMatrix());
  ASSERT_EQ(raw.intensity.size(), values.size());
  for (std::size_t i = 0; i < values.size(); ++i) EXPECT_EQ(raw.intensity[i], values[i]) << i;
  EXPECT_EQ(raw.min_intensity, -32768.0);
  EXPECT_EQ(raw.max_intensity, 32767.0);

  // load_volume picks .nhdr up by extension.
  const DensityField field =
      load_volume(dir + "/vol.nhdr", {IntensityMapping::Kind::kThreshold, 10.0, 0.0});
  EXPECT_EQ(field.active_voxel_count(), 7u);  // 32767, 500 and 10..14
}

TEST(VolumeIoNrrd, LineSkipAndDatafileSpellingAndLastBytes) {
  const std::string dir = scratch_dir();
  const std::vector<std::uint16_t> values = {1, 2, 3, 4, 5, 6, 7, 8};
  write_file(dir + "/a.dat", "line one\nline two\n" + to_bytes(values, false));
  write_file(dir + "/a.nhdr",
             "NRRD0004\ntype: unsigned short\ndimension: 3\nsizes: 2 2 2\nendian: little\n"
             "encoding: raw\nline skip: 2\ndatafile: a.dat\n");
  RawVolume raw = read_nrrd(dir + "/a.nhdr");
  EXPECT_EQ(raw.spacing_mm, Vec3d::Ones());  // no spacing given
  EXPECT_EQ(raw.intensity, std::vector<float>({1, 2, 3, 4, 5, 6, 7, 8}));

  // byte skip -1: the payload is the file's last bytes.
  write_file(dir + "/b.nhdr",
             "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 2 2 2\nendian: little\n"
             "encoding: raw\nbyte skip: -1\ndata file: a.dat\n");
  raw = read_nrrd(dir + "/b.nhdr");
  EXPECT_EQ(raw.intensity, std::vector<float>({1, 2, 3, 4, 5, 6, 7, 8}));
}

TEST(VolumeIoNrrd, GzipWithByteSkipAndTrailingGarbage) {
  const std::vector<float> values = {0.5f, -1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f, 1e6f};
  // Byte skip applies after decompression for compressed encodings.
  const std::string payload = gzip("SKIP" + to_bytes(values, false)) + "trailing garbage";
  const std::string path = scratch_dir() + "/g.nrrd";
  write_file(path, make_nrrd(with(basic_fields("float", "gz"), "byte skip: 4"), payload));
  const RawVolume raw = read_nrrd(path);
  EXPECT_EQ(raw.intensity, values);
}

TEST(VolumeIoNrrd, HeaderCommentsCrlfAndKeyValuesIgnored) {
  const std::string path = scratch_dir() + "/c.nrrd";
  write_file(path,
             "NRRD0004\r\n# comment: with colon\r\ntype: uchar\r\ndimension: 3\r\n"
             "sizes: 2 2 2\r\nmodality:=CT\r\ncontent: test\r\nencoding: raw\r\n\r\n" +
                 kEightBytes);
  const RawVolume raw = read_nrrd(path);
  EXPECT_EQ(raw.intensity, std::vector<float>({1, 2, 3, 4, 5, 6, 7, 8}));
}

// Every sample type (with every NRRD spelling) and both byte orders round trip.
TEST(VolumeIoNrrd, EverySampleTypeRoundTrips) {
  const std::string dir = scratch_dir();
  int file_index = 0;
  auto check = [&](const std::vector<std::string>& spellings, const std::string& normalised,
                   auto values) {
    for (const std::string& spelling : spellings) {
      for (bool big : {false, true}) {
        const std::string path = dir + "/t" + std::to_string(file_index++) + ".nrrd";
        write_file(path, make_nrrd(with(basic_fields(spelling, big ? "gzip" : "raw"),
                                        big ? "endian: big" : "endian: little"),
                                   big ? gzip(to_bytes(values, true)) : to_bytes(values, false)));
        SCOPED_TRACE(spelling + (big ? " big gzip" : " little raw"));
        const RawVolume raw = read_nrrd(path);
        EXPECT_EQ(raw.sample_type, normalised);
        ASSERT_EQ(raw.intensity.size(), 8u);
        for (std::size_t i = 0; i < 8; ++i) {
          EXPECT_EQ(raw.intensity[i], static_cast<float>(values[i])) << i;
        }
      }
    }
  };
  check({"signed char", "int8", "int8_t"}, "int8",
        std::vector<std::int8_t>{-128, -1, 0, 1, 2, 3, 100, 127});
  check({"uchar", "unsigned char", "uint8", "uint8_t"}, "uint8",
        std::vector<std::uint8_t>{0, 1, 2, 3, 4, 128, 200, 255});
  check({"short", "short int", "signed short", "signed short int", "int16", "int16_t"}, "int16",
        std::vector<std::int16_t>{-32768, -2, 0, 1, 258, 1000, 30000, 32767});
  check({"ushort", "unsigned short", "unsigned short int", "uint16", "uint16_t"}, "uint16",
        std::vector<std::uint16_t>{0, 1, 258, 1000, 30000, 40000, 65534, 65535});
  check({"int", "signed int", "int32", "int32_t"}, "int32",
        std::vector<std::int32_t>{-2000000000, -70000, -1, 0, 1, 65536, 16777216, 2000000000});
  check({"uint", "unsigned int", "uint32", "uint32_t"}, "uint32",
        std::vector<std::uint32_t>{0, 1, 65536, 16777216, 100000, 7, 3000000000u, 4000000000u});
  check({"longlong", "long long", "long long int", "signed long long", "signed long long int",
         "int64", "int64_t"},
        "int64",
        std::vector<std::int64_t>{-(std::int64_t{1} << 40), -5, 0, 1, 2, 1 << 20, 1 << 24,
                                  std::int64_t{1} << 50});
  check({"ulonglong", "unsigned long long", "unsigned long long int", "uint64", "uint64_t"},
        "uint64",
        std::vector<std::uint64_t>{0, 1, 2, 3, 1 << 20, 1 << 24, std::uint64_t{1} << 40,
                                   std::uint64_t{1} << 63});
  check({"float", "FLOAT"}, "float",
        std::vector<float>{-1.5f, 0.0f, 1e-30f, 0.25f, 3.0f, 1e30f, -7.0f, 0.1f});
  check({"double"}, "double", std::vector<double>{-1.5, 0.0, 1e-30, 0.25, 3.0, 1e30, -7.0, 0.1});
}

// ---- bad NRRD input ------------------------------------------------------------------

TEST(VolumeIoNrrdErrors, MissingFile) {
  const std::string path = scratch_dir() + "/nope.nrrd";
  expect_input_error([&] { read_nrrd(path); }, path, "cannot open file");
  expect_input_error([&] { load_volume(path, {}); }, path, "cannot open file");
}

TEST(VolumeIoNrrdErrors, BadMagic) {
  expect_nrrd_error("magic.nrrd", "P6\n2 2\n255\n" + kEightBytes, "not a NRRD file");
  expect_nrrd_error("empty.nrrd", "", "not a NRRD file");
  expect_nrrd_error("magicx.nrrd", "NRRD000X\n", "not a NRRD file");
}

TEST(VolumeIoNrrdErrors, DimensionTwo) {
  expect_nrrd_error(
      "dim2.nrrd", make_nrrd(with(with(basic_fields(), "dimension: 2"), "sizes: 2 4"), kEightBytes),
      "dimension 2 is not supported");
}

TEST(VolumeIoNrrdErrors, UnsupportedEncodingTypeAndKinds) {
  expect_nrrd_error("ascii.nrrd", make_nrrd(basic_fields("uint8", "ascii"), "1 2 3 4 5 6 7 8"),
                    "unsupported encoding 'ascii'");
  expect_nrrd_error("bz.nrrd", make_nrrd(basic_fields("uint8", "bzip2"), kEightBytes),
                    "unsupported encoding 'bzip2'");
  expect_nrrd_error("hex.nrrd", make_nrrd(basic_fields("uint8", "hex"), "0102030405060708"),
                    "unsupported encoding 'hex'");
  expect_nrrd_error("block.nrrd", make_nrrd(basic_fields("block"), kEightBytes),
                    "unsupported sample type 'block'");
  expect_nrrd_error("kinds.nrrd",
                    make_nrrd(with(basic_fields(), "kinds: vector domain domain"), kEightBytes),
                    "axis kind 'vector' is not supported");
}

TEST(VolumeIoNrrdErrors, ANulInAValueIsShownNotWhereTheMessageStops) {
  // The message was cut at the NUL, as a C string stops there.
  const std::string encoding = std::string("gz\0ip", 5);
  expect_nrrd_error("nul.nrrd", make_nrrd(basic_fields("uint8", encoding), kEightBytes),
                    "unsupported encoding 'gz\\x00ip' (expected raw or gzip)");
  expect_nrrd_error("nul_sizes.nrrd",
                    make_nrrd(with(basic_fields(), std::string("sizes: 2 2\0 2", 13)), kEightBytes),
                    "sizes must be positive integers, got '2 2\\x00 2'");
}

TEST(VolumeIoNrrdErrors, SizesOverTheInputBudgetAreRefusedBeforeReading) {
  expect_nrrd_error("big.nrrd",
                    make_nrrd(with(basic_fields("float"), "sizes: 1024 1024 1024"), kEightBytes),
                    "1024 x 1024 x 1024 float samples take 4096 MB decoded, over the limit of "
                    "2048 MB (raise it with --max-input-mb)");
}

TEST(VolumeIoNrrdErrors, TruncatedRaw) {
  expect_nrrd_error("short.nrrd", make_nrrd(basic_fields("uint16"), kEightBytes + "ab"),
                    "truncated data: expected 16 bytes, got 10");
  expect_nrrd_error("long.nrrd", make_nrrd(basic_fields(), kEightBytes + "x"),
                    "too much data: expected 8 bytes, got 9");
  // A header claiming gigabytes over a tiny payload fails fast, without allocating them:
  // past --max-input-mb from the header, and within a raised limit at the payload's end.
  expect_nrrd_error("over8gb.nrrd",
                    make_nrrd(with(basic_fields("double"), "sizes: 1000 1000 1000"), kEightBytes),
                    "1000 x 1000 x 1000 double samples take 7630 MB decoded");
  InputLimits& limits = input_limits();
  const InputLimits saved = limits;
  limits.max_input_mb = 8000;
  expect_nrrd_error("claims8gb.nrrd",
                    make_nrrd(with(basic_fields("double"), "sizes: 1000 1000 1000"), kEightBytes),
                    "truncated data: expected 8000000000 bytes, got 8");
  expect_nrrd_error(
      "claims8gb_gz.nrrd",
      make_nrrd(with(basic_fields("double", "gzip"), "sizes: 1000 1000 1000"), gzip(kEightBytes)),
      "truncated data: expected 8000000000 bytes, got 8");
  limits = saved;
}

TEST(VolumeIoNrrdErrors, TruncatedGzip) {
  std::string payload(4000, '\0');
  for (std::size_t i = 0; i < payload.size(); ++i) payload[i] = static_cast<char>(i * 7919 % 251);
  const std::string gz = gzip(payload);
  auto fields = with(basic_fields("float", "gzip"), "sizes: 10 10 10");
  // Well-formed stream, too little data.
  expect_nrrd_error("gzshort.nrrd", make_nrrd(fields, gzip(payload.substr(0, 1000))),
                    "truncated data: expected 4000 bytes, got 1000");
  // The file itself is cut short.
  expect_nrrd_error("gzcut.nrrd", make_nrrd(fields, gz.substr(0, gz.size() / 2)),
                    "truncated data: expected 4000 bytes, got ");
  // Only the trailer is missing.
  expect_nrrd_error("gztrailer.nrrd", make_nrrd(fields, gz.substr(0, gz.size() - 4)),
                    "truncated data");
}

TEST(VolumeIoNrrdErrors, CorruptGzip) {
  std::string gz = gzip(std::string(4000, 'a'));
  for (std::size_t i = 10; i < gz.size(); ++i) gz[i] = '\xff';
  expect_nrrd_error("gzbad.nrrd",
                    make_nrrd(with(basic_fields("float", "gzip"), "sizes: 10 10 10"), gz),
                    "corrupt gzip data: ");
  // Raw bytes labelled gzip.
  expect_nrrd_error("notgz.nrrd", make_nrrd(basic_fields("uint8", "gzip"), kEightBytes),
                    "corrupt gzip data: ");
}

TEST(VolumeIoNrrdErrors, NanOrInfinityInFloatData) {
  std::vector<float> values(8, 1.0f);
  values[3] = std::numeric_limits<float>::quiet_NaN();
  expect_nrrd_error("nan.nrrd", make_nrrd(basic_fields("float"), to_bytes(values, false)),
                    "contains NaN or infinite values");
  std::vector<double> dvalues(8, 1.0);
  dvalues[7] = -std::numeric_limits<double>::infinity();
  expect_nrrd_error("inf.nrrd", make_nrrd(basic_fields("double"), to_bytes(dvalues, false)),
                    "contains NaN or infinite values");
}

TEST(VolumeIoNrrdErrors, BadSpacing) {
  expect_nrrd_error("zero.nrrd", make_nrrd(with(basic_fields(), "spacings: 1 0 1"), kEightBytes),
                    "spacing must be positive and finite");
  expect_nrrd_error("neg.nrrd", make_nrrd(with(basic_fields(), "spacings: -1 1 1"), kEightBytes),
                    "spacing must be positive and finite");
  expect_nrrd_error("nanspacing.nrrd",
                    make_nrrd(with(basic_fields(), "spacings: 1 nan 1"), kEightBytes),
                    "spacing must be positive and finite");
  expect_nrrd_error("zerodir.nrrd",
                    make_nrrd(with(with(basic_fields(), "spacings:"),
                                   "space directions: (0,0,0) (0,1,0) (0,0,1)"),
                              kEightBytes),
                    "spacing must be positive and finite");
}

TEST(VolumeIoNrrdErrors, BadOrMissingSizes) {
  expect_nrrd_error("nosizes.nrrd", make_nrrd(with(basic_fields(), "sizes:"), kEightBytes),
                    "missing required field 'sizes'");
  expect_nrrd_error("notype.nrrd", make_nrrd(with(basic_fields(), "type:"), kEightBytes),
                    "missing required field 'type'");
  expect_nrrd_error("zerosize.nrrd", make_nrrd(with(basic_fields(), "sizes: 2 0 2"), kEightBytes),
                    "sizes must be positive integers");
  expect_nrrd_error("negsize.nrrd", make_nrrd(with(basic_fields(), "sizes: 2 -2 2"), kEightBytes),
                    "sizes must be positive integers");
  expect_nrrd_error("hugesize.nrrd",
                    make_nrrd(with(basic_fields(), "sizes: 100000 100000 100000"), kEightBytes),
                    "too large");
  expect_nrrd_error("twosizes.nrrd", make_nrrd(with(basic_fields(), "sizes: 2 2"), kEightBytes),
                    "sizes must list 3 values");
  expect_nrrd_error("noendian.nrrd",
                    make_nrrd(with(basic_fields("uint16"), "endian:"), kEightBytes + kEightBytes),
                    "missing required field 'endian'");
}

TEST(VolumeIoNrrdErrors, MissingDetachedDataFile) {
  const std::string dir = scratch_dir();
  const std::string path = dir + "/d.nhdr";
  write_file(path, make_nrrd(with(basic_fields(), "data file: missing.raw"), ""));
  expect_input_error([&] { read_nrrd(path); }, path, "cannot open data file");
  expect_input_error([&] { read_nrrd(path); }, path, "missing.raw");
  // A detached header with neither a data file nor a blank line has no data at all.
  write_file(path, "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n");
  expect_input_error([&] { read_nrrd(path); }, path, "no data");
}

// ---- intensity mapping ---------------------------------------------------------------

TEST(VolumeIoNrrd, SpaceDirectionsKeepOrientationInLps) {
  // RAS space: a vector (x, y, z) there is (-x, -y, z) in LPS, and so is the origin.
  const std::vector<std::string> fields = {"type: uint8",
                                           "dimension: 3",
                                           "space: right-anterior-superior",
                                           "sizes: 2 2 2",
                                           "space directions: (0,0.5,0) (-2,0,0) (0,0,1.5)",
                                           "space origin: (10,20,30)",
                                           "encoding: raw"};
  const std::string path = scratch_dir() + "/ras.nrrd";
  write_file(path, make_nrrd(fields, kEightBytes));
  const RawVolume raw = read_nrrd(path);
  EXPECT_EQ(raw.spacing_mm, Vec3d(0.5, 2.0, 1.5));
  Mat3d expected;
  expected << 0, 1, 0,  //
      -1, 0, 0,         //
      0, 0, 1;
  EXPECT_EQ(raw.direction, expected);
  EXPECT_EQ(raw.origin_mm, Vec3d(-10, -20, 30));
  // Index (1, 1, 0) in world: origin + 0.5 * i axis + 2 * j axis.
  const DensityField field = map_to_density(raw, {IntensityMapping::Kind::kThreshold, 0.0}, path);
  EXPECT_TRUE(field.index_to_world(Vec3d(1, 1, 0)).isApprox(Vec3d(-10 + 2, -20 - 0.5, 30)));

  write_file(path,
             make_nrrd(with(fields, "space directions: (1,0,0) (1,1,0) (0,0,1)"), kEightBytes));
  expect_input_error([&] { read_nrrd(path); }, path, "space directions are not orthonormal");
  write_file(path, make_nrrd(with(fields, "space: right-anterior-superior-time"), kEightBytes));
  expect_input_error([&] { read_nrrd(path); }, path, "is not supported");
}

TEST(VolumeIoNrrd, OrientedDensityRoundTripIsExact) {
  const DensityField plain = make_test_field();
  const Mat3d turn = Eigen::AngleAxisd(-1.1, Vec3d(0.3, -1, 0.2).normalized()).toRotationMatrix();
  const DensityField field(plain.grid().deepCopy(), plain.voxel_size_mm(), plain.origin_mm(),
                           plain.dims(), turn);
  const std::string path = scratch_dir() + "/turned.nrrd";
  write_nrrd(field, path);
  const RawVolume raw = read_nrrd(path);
  EXPECT_TRUE(raw.holds_density);
  EXPECT_TRUE(raw.direction.isApprox(turn, 1e-15)) << raw.direction - turn;
  EXPECT_TRUE(raw.spacing_mm.isApprox(field.voxel_size_mm(), 1e-15));
  EXPECT_EQ(raw.origin_mm, field.origin_mm());
  // Read back as density, not through the Otsu threshold: every partial density kept.
  const DensityField back = load_volume(path, {});
  EXPECT_EQ(back.total_density(), field.total_density());
  EXPECT_EQ(back.active_voxel_count(), field.active_voxel_count());
}

}  // namespace
}  // namespace hapvox::engine
