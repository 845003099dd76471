#pragma once
// Helpers shared by the volume reader and writer tests: files of given bytes, gzip, NRRDs
// built field by field, and checks of InputError's source and problem.

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <bit>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/volume_io.h"
#include "test_data.h"

namespace hapvox::engine::io_test {

using ::hapvox::testing::scratch_dir;
using ::testing::HasSubstr;

// ---- helpers -------------------------------------------------------------------------

inline void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ASSERT_TRUE(out.good()) << path;
}

inline std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

inline std::string gzip(const std::string& bytes) {
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

inline std::string zlib(const std::string& bytes) {
  uLongf size = compressBound(static_cast<uLong>(bytes.size()));
  std::string out(size, '\0');
  EXPECT_EQ(
      compress2(reinterpret_cast<Bytef*>(out.data()), &size,
                reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uLong>(bytes.size()), 6),
      Z_OK);
  out.resize(size);
  return out;
}

// Serialises samples with the given byte order.
template <typename T>
inline std::string to_bytes(const std::vector<T>& values, bool big_endian) {
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
inline std::string make_nrrd(const std::vector<std::string>& fields, const std::string& payload) {
  std::string s = "NRRD0004\n";
  for (const auto& f : fields) s += f + "\n";
  return s + "\n" + payload;
}

inline std::vector<std::string> basic_fields(const std::string& type = "uint8",
                                             const std::string& encoding = "raw") {
  return {"type: " + type,   "dimension: 3",   "sizes: 2 2 2",
          "spacings: 1 1 1", "endian: little", "encoding: " + encoding};
}

// Replaces the field with the same name as `line` (or drops it if `line` is just "name:").
inline std::vector<std::string> with(std::vector<std::string> fields, const std::string& line) {
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

inline const std::string kEightBytes = std::string("\x01\x02\x03\x04\x05\x06\x07\x08", 8);

// Runs `fn`, expecting an InputError naming `source` whose problem mentions `problem`.
inline void expect_input_error(const std::function<void()>& fn, const std::string& source,
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

inline void expect_nrrd_error(const std::string& name, const std::string& contents,
                              const std::string& problem) {
  const std::string path = scratch_dir() + "/" + name;
  write_file(path, contents);
  expect_input_error([&] { read_nrrd(path); }, path, problem);
}

inline std::size_t count_at_least(const RawVolume& raw, double t) {
  return static_cast<std::size_t>(
      std::count_if(raw.intensity.begin(), raw.intensity.end(), [t](float v) { return v >= t; }));
}

inline void expect_densities_in_unit_range(const DensityField& field) {
  for (auto it = field.grid().cbeginValueOn(); it; ++it) {
    ASSERT_GT(*it, 0.0f) << it.getCoord();
    ASSERT_LE(*it, 1.0f) << it.getCoord();
  }
  // Background: inactive zeros, no active tiles hiding voxels.
  EXPECT_EQ(field.grid().background(), 0.0f);
  EXPECT_EQ(field.grid().tree().activeTileCount(), 0u);
}

// A small field with anisotropic spacing, an offset origin and varied values.
inline DensityField make_test_field() {
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

}  // namespace hapvox::engine::io_test
