#include "engine/io/written_volume.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <sstream>

#include "engine/errors.h"
#include "engine/io/payload.h"

namespace hapvox::engine::io {
namespace {

template <typename T>
void pack(const std::vector<float>& values, std::vector<unsigned char>& bytes) {
  bytes.resize(values.size() * sizeof(T));
  for (std::size_t i = 0; i < values.size(); ++i) {
    const T v = static_cast<T>(values[i]);
    std::memcpy(bytes.data() + i * sizeof(T), &v, sizeof(T));
  }
}

template <typename T>
void unpack(const std::vector<unsigned char>& bytes, std::vector<std::int32_t>& labels) {
  labels.resize(bytes.size() / sizeof(T));
  for (std::size_t i = 0; i < labels.size(); ++i) {
    T v;
    std::memcpy(&v, bytes.data() + i * sizeof(T), sizeof(T));
    labels[i] = static_cast<std::int32_t>(v);
  }
}

}  // namespace

int sample_bytes(WrittenType type) {
  switch (type) {
    case WrittenType::float32:
    case WrittenType::int32:
      return 4;
    case WrittenType::uint16:
      return 2;
    case WrittenType::uint8:
      return 1;
  }
  return 0;
}

const char* nrrd_type_name(WrittenType type) {
  switch (type) {
    case WrittenType::float32:
      return "float";
    case WrittenType::uint8:
      return "uint8";
    case WrittenType::uint16:
      return "uint16";
    case WrittenType::int32:
      return "int32";
  }
  return "";
}

WrittenVolume density_to_write(const DensityField& field) {
  WrittenVolume volume;
  volume.content = WrittenContent::density;
  volume.type = WrittenType::float32;
  const std::vector<float> values = dense_floats(field);
  const auto* begin = reinterpret_cast<const unsigned char*>(values.data());
  volume.bytes.assign(begin, begin + values.size() * sizeof(float));
  volume.dims = field.dims();
  volume.spacing_mm = field.voxel_size_mm();
  volume.origin_mm = field.origin_mm();
  volume.direction = field.direction();
  return volume;
}

WrittenVolume labels_to_write(const RawVolume& labels, const std::string& source) {
  float largest = 0.0f;
  for (std::size_t i = 0; i < labels.intensity.size(); ++i) {
    const float v = labels.intensity[i];
    if (!(v >= 0.0f && v <= static_cast<float>(kMaxWrittenLabel) && std::floor(v) == v)) {
      const std::int64_t n = static_cast<std::int64_t>(i);
      const std::int64_t nx = labels.dims.x(), nxy = nx * labels.dims.y();
      std::ostringstream message;
      message << "voxel (" << n % nx << ", " << n / nx % labels.dims.y() << ", " << n / nxy
              << ") holds " << v << ", not a label (an integer in [0, " << kMaxWrittenLabel << "])";
      throw InputError(source, message.str());
    }
    largest = std::max(largest, v);
  }
  WrittenVolume volume;
  volume.content = WrittenContent::labels;
  if (largest <= 255.0f) {
    volume.type = WrittenType::uint8;
    pack<std::uint8_t>(labels.intensity, volume.bytes);
  } else if (largest <= 65535.0f) {
    volume.type = WrittenType::uint16;
    pack<std::uint16_t>(labels.intensity, volume.bytes);
  } else {
    volume.type = WrittenType::int32;
    pack<std::int32_t>(labels.intensity, volume.bytes);
  }
  volume.dims = labels.dims;
  volume.spacing_mm = labels.spacing_mm;
  volume.origin_mm = labels.origin_mm;
  volume.direction = labels.direction;
  return volume;
}

std::vector<std::int32_t> written_labels(const WrittenVolume& volume) {
  std::vector<std::int32_t> labels;
  switch (volume.type) {
    case WrittenType::uint8:
      unpack<std::uint8_t>(volume.bytes, labels);
      break;
    case WrittenType::uint16:
      unpack<std::uint16_t>(volume.bytes, labels);
      break;
    case WrittenType::int32:
      unpack<std::int32_t>(volume.bytes, labels);
      break;
    case WrittenType::float32: {
      std::vector<float> values(volume.bytes.size() / sizeof(float));
      std::memcpy(values.data(), volume.bytes.data(), values.size() * sizeof(float));
      labels.resize(values.size());
      std::transform(values.begin(), values.end(), labels.begin(),
                     [](float v) { return static_cast<std::int32_t>(v); });
      break;
    }
  }
  return labels;
}

}  // namespace hapvox::engine::io
