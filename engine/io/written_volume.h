#pragma once
// A volume as the NRRD, MetaImage and NIfTI writers write it: dense samples of one type,
// the grid's geometry and what the samples are. Densities are written as float with
// metadata saying so (they read back as densities, not through the intensity mapping);
// label maps as the smallest integer type that holds them (uint8, uint16 or int32), with
// metadata saying they are labels, so Slicer and ITK open them as label maps.

#include <cstdint>
#include <string>
#include <vector>

#include "engine/density_field.h"
#include "engine/io/raw_volume.h"

namespace hapvox::engine::io {

/// The largest label a label map may hold: every label is exact as a float sample too.
constexpr std::int32_t kMaxWrittenLabel = 1 << 24;

enum class WrittenContent { density, labels };
enum class WrittenType { float32, uint8, uint16, int32 };

/// Bytes per sample, and the type's name in NRRD ("float", "uint8", "uint16", "int32").
int sample_bytes(WrittenType type);
const char* nrrd_type_name(WrittenType type);

struct WrittenVolume {
  WrittenContent content = WrittenContent::density;
  WrittenType type = WrittenType::float32;
  std::vector<unsigned char> bytes;  // dims.prod() samples of `type`, native byte order, x fastest
  Vec3i dims = Vec3i::Zero();
  Vec3d spacing_mm = Vec3d::Ones();
  Vec3d origin_mm = Vec3d::Zero();
  Mat3d direction = Mat3d::Identity();  // world (LPS) direction of each index axis, as columns
};

/// The field's densities over its index box [0, dims) as float samples.
WrittenVolume density_to_write(const DensityField& field);

/// A label map's samples (integers in [0, kMaxWrittenLabel], as read_scalar_volume reads
/// any volume) as the smallest of uint8, uint16 and int32 that holds its largest label.
/// Throws InputError(source, ...) naming the first voxel whose value is no such integer.
WrittenVolume labels_to_write(const RawVolume& labels, const std::string& source);

/// The samples of a label map as int32 (for writers of typed grids: OpenVDB's Int32Grid).
std::vector<std::int32_t> written_labels(const WrittenVolume& volume);

}  // namespace hapvox::engine::io
