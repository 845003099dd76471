#include "engine/volume_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "engine/errors.h"
#include "test_data.h"

namespace hapvox::engine {
namespace {

using ::hapvox::testing::scratch_dir;
using ::hapvox::testing::source_path;
using ::testing::HasSubstr;

// ---- helpers -------------------------------------------------------------------------

void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ASSERT_TRUE(out.good()) << path;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::string gzip(const std::string& bytes) {
  z_stream zs{};
  EXPECT_EQ(deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::string out(deflateBound(&zs, bytes.size()), '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  zs.avail_in = static_cast<uInt>(bytes.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  return out;
}

// Serialises samples with the given byte order.
template <typename T>
std::string to_bytes(const std::vector<T>& values, bool big_endian) {
  std::string out;
  for (const T& v : values) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (big_endian != (std::endian::native == std::endian::big)) std::reverse(b, b + sizeof(T));
    out.append(b, sizeof(T));
  }
  return out;
}

// An attached-header NRRD; `fields` are the header lines after the magic.
std::string make_nrrd(const std::vector<std::string>& fields, const std::string& payload) {
  std::string s = "NRRD0004\n";
  for (const auto& f : fields) s += f + "\n";
  return s + "\n" + payload;
}

std::vector<std::string> basic_fields(const std::string& type = "uint8",
                                      const std::string& encoding = "raw") {
  return {"type: " + type,   "dimension: 3",   "sizes: 2 2 2",
          "spacings: 1 1 1", "endian: little", "encoding: " + encoding};
}

// Replaces the field with the same name as `line` (or drops it if `line` is just "name:").
std::vector<std::string> with(std::vector<std::string> fields, const std::string& line) {
  const std::string key = line.substr(0, line.find(':') + 1);
  auto it = std::find_if(fields.begin(), fields.end(),
                         [&](const std::string& f) { return f.rfind(key, 0) == 0; });
  if (it == fields.end()) {
    fields.push_back(line);
  } else if (line == key) {
    fields.erase(it);
  } else {
    *it = line;
  }
  return fields;
}

const std::string kEightBytes = std::string("\x01\x02\x03\x04\x05\x06\x07\x08", 8);

// Runs `fn`, expecting an InputError naming `source` whose problem mentions `problem`.
void expect_input_error(const std::function<void()>& fn, const std::string& source,
                        const std::string& problem) {
  try {
    fn();
    ADD_FAILURE() << "no InputError; expected '" << problem << "'";
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), source) << e.what();
    EXPECT_THAT(e.what(), HasSubstr(source));
    EXPECT_THAT(e.problem(), HasSubstr(problem)) << e.what();
  }
}

void expect_nrrd_error(const std::string& name, const std::string& contents,
                       const std::string& problem) {
  const std::string path = scratch_dir() + "/" + name;
  write_file(path, contents);
  expect_input_error([&] { read_nrrd(path); }, path, problem);
}

std::size_t count_at_least(const RawVolume& raw, double t) {
  return static_cast<std::size_t>(
      std::count_if(raw.intensity.begin(), raw.intensity.end(), [t](float v) { return v >= t; }));
}

void expect_densities_in_unit_range(const DensityField& field) {
  for (auto it = field.grid().cbeginValueOn(); it; ++it) {
    ASSERT_GT(*it, 0.0f) << it.getCoord();
    ASSERT_LE(*it, 1.0f) << it.getCoord();
  }
  // Background: inactive zeros, no active tiles hiding voxels.
  EXPECT_EQ(field.grid().background(), 0.0f);
  EXPECT_EQ(field.grid().tree().activeTileCount(), 0u);
}

// A small field with anisotropic spacing, an offset origin and varied values.
DensityField make_test_field() {
  auto grid = openvdb::FloatGrid::create(0.0f);
  auto acc = grid->getAccessor();
  const Vec3i dims(5, 6, 7);
  for (int z = 0; z < dims.z(); ++z) {
    for (int y = 0; y < dims.y(); ++y) {
      for (int x = 0; x < dims.x(); ++x) {
        const int h = (x * 7 + y * 13 + z * 29) % 11;
        if (h > 2) acc.setValueOn(openvdb::Coord(x, y, z), static_cast<float>(h) / 10.0f - 0.05f);
      }
    }
  }
  return DensityField(grid, Vec3d(0.5, 0.75, 1.25), Vec3d(-3.0, 2.0, 7.5), dims);
}

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
  EXPECT_EQ(raw.origin_mm, Vec3d(1.0, 2.5, -3.0));
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

TEST(VolumeIoNrrdErrors, TruncatedRaw) {
  expect_nrrd_error("short.nrrd", make_nrrd(basic_fields("uint16"), kEightBytes + "ab"),
                    "truncated data: expected 16 bytes, got 10");
  expect_nrrd_error("long.nrrd", make_nrrd(basic_fields(), kEightBytes + "x"),
                    "too much data: expected 8 bytes, got 9");
  // A header claiming gigabytes over a tiny payload fails fast, without allocating them.
  expect_nrrd_error("claims8gb.nrrd",
                    make_nrrd(with(basic_fields("double"), "sizes: 1000 1000 1000"), kEightBytes),
                    "truncated data: expected 8000000000 bytes, got 8");
  expect_nrrd_error(
      "claims8gb_gz.nrrd",
      make_nrrd(with(basic_fields("double", "gzip"), "sizes: 1000 1000 1000"), gzip(kEightBytes)),
      "truncated data: expected 8000000000 bytes, got 8");
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

TEST(VolumeIoVdb, WriteReadRoundTrip) {
  const DensityField field = make_test_field();
  const std::string path = scratch_dir() + "/field.vdb";
  write_vdb(field, path);
  EXPECT_FALSE(std::filesystem::exists(path + ".partial"));
  // The field's own grid is untouched by naming and metadata.
  EXPECT_EQ(field.grid()["hapvox_dims"], nullptr);

  const DensityField back = read_vdb(path);
  EXPECT_EQ(back.dims(), field.dims());
  EXPECT_TRUE(back.voxel_size_mm().isApprox(field.voxel_size_mm(), 1e-12));
  EXPECT_TRUE(back.origin_mm().isApprox(field.origin_mm(), 1e-12));
  EXPECT_EQ(back.active_voxel_count(), field.active_voxel_count());
  auto acc = back.grid().getConstAccessor();
  for (auto it = field.grid().cbeginValueOn(); it; ++it) {
    ASSERT_TRUE(acc.isValueOn(it.getCoord()));
    ASSERT_EQ(acc.getValue(it.getCoord()), *it);
  }
  // Same through load_volume.
  EXPECT_EQ(load_volume(path, {}).active_voxel_count(), field.active_voxel_count());
}

TEST(VolumeIoVdb, FirstFloatGridAndBoundingBoxDims) {
  initialize_openvdb();
  const std::string path = scratch_dir() + "/other.vdb";
  auto ints = openvdb::Int32Grid::create(0);
  ints->setName("density");  // right name, wrong type: skipped
  auto grid = openvdb::FloatGrid::create(0.0f);
  grid->setName("fog");
  grid->tree().setValueOn(openvdb::Coord(3, 4, 5), 0.5f);
  grid->setTransform(openvdb::math::Transform::createLinearTransform(0.25));
  openvdb::io::File(path).write(openvdb::GridCPtrVec{ints, grid});

  const DensityField field = read_vdb(path);
  EXPECT_EQ(field.dims(), Vec3i(4, 5, 6));
  EXPECT_EQ(field.voxel_size_mm(), Vec3d::Constant(0.25));
  EXPECT_EQ(field.origin_mm(), Vec3d::Zero());
  EXPECT_DOUBLE_EQ(field.total_density(), 0.5);
}

TEST(VolumeIoVdbErrors, MissingNotVdbNoFloatGrid) {
  initialize_openvdb();
  const std::string dir = scratch_dir();
  expect_input_error([&] { read_vdb(dir + "/missing.vdb"); }, dir + "/missing.vdb",
                     "cannot open file");

  write_file(dir + "/text.vdb", "this is not a vdb file\n");
  expect_input_error([&] { read_vdb(dir + "/text.vdb"); }, dir + "/text.vdb", "not a VDB file");

  auto ints = openvdb::Int32Grid::create(0);
  ints->setName("density");
  openvdb::io::File(dir + "/ints.vdb").write(openvdb::GridCPtrVec{ints});
  expect_input_error([&] { read_vdb(dir + "/ints.vdb"); }, dir + "/ints.vdb", "no float grid");

  auto level_set = openvdb::FloatGrid::create(3.0f);
  level_set->setGridClass(openvdb::GRID_LEVEL_SET);
  openvdb::io::File(dir + "/ls.vdb").write(openvdb::GridCPtrVec{level_set});
  expect_input_error([&] { read_vdb(dir + "/ls.vdb"); }, dir + "/ls.vdb", "level set");
}

// ---- generators ----------------------------------------------------------------------

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

TEST(VolumeIoGenerators, SphereMassMatchesVolume) {
  const DensityField sphere = generate_volume("sphere:dims=64,voxel_mm=0.5,radius_mm=10");
  const double r_voxels = 10.0 / 0.5;
  const double expected = 4.0 / 3.0 * std::numbers::pi * std::pow(r_voxels, 3);
  EXPECT_NEAR(sphere.total_density(), expected, 0.02 * expected);
  expect_densities_in_unit_range(sphere);
  // Centred: symmetric about the box centre.
  EXPECT_TRUE(sphere.grid().tree().isValueOn(openvdb::Coord(31, 31, 31 - 19)));
  EXPECT_TRUE(sphere.grid().tree().isValueOn(openvdb::Coord(31, 31, 32 + 19)));
  EXPECT_FALSE(sphere.grid().tree().isValueOn(openvdb::Coord(0, 0, 0)));

  const DensityField by_default = generate_volume("sphere:dims=40");
  const double r = 0.35 * 40;
  const double expected_default = 4.0 / 3.0 * std::numbers::pi * r * r * r;
  EXPECT_NEAR(by_default.total_density(), expected_default, 0.02 * expected_default);
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

TEST(VolumeIoLoad, DispatchesByExtensionAndRejectsUnknown) {
  const DensityField gen = load_volume("block:dims=8", {});
  EXPECT_EQ(gen.active_voxel_count(), 8u * 8u * 4u);

  const std::string dir = scratch_dir();
  write_file(dir + "/v.NRRD", make_nrrd(basic_fields(), kEightBytes));
  EXPECT_EQ(load_volume(dir + "/v.NRRD", {IntensityMapping::Kind::kThreshold, 5.0, 0.0})
                .active_voxel_count(),
            4u);

  write_file(dir + "/v.raw", kEightBytes);
  const std::string problem = "unknown volume format (expected .nrrd, .nhdr or .vdb";
  expect_input_error([&] { load_volume(dir + "/v.raw", {}); }, dir + "/v.raw", problem);
  expect_input_error([&] { load_volume(dir + "/missing.tiff", {}); }, dir + "/missing.tiff",
                     problem);
  expect_input_error([&] { load_volume("cube:dims=3", {}); }, "cube:dims=3", problem);
}

}  // namespace
}  // namespace hapvox::engine
