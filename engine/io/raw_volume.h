#pragma once
// A scalar volume as a reader finds it on disk, before intensities become densities.

#include <cstdint>
#include <string>
#include <vector>

#include "engine/density_field.h"

namespace hapvox::engine::io {

/// Volumes larger than this many samples are almost surely a corrupt header (and would not
/// fit our int indexing anyway): readers refuse them before allocating anything.
constexpr std::int64_t kMaxSamples = std::int64_t{1} << 31;

/// A scalar volume as read from disk, before mapping to density. x varies fastest.
struct RawVolume {
  std::vector<float> intensity;  // dims.prod() samples, converted to float
  Vec3i dims = Vec3i::Zero();
  Vec3d spacing_mm = Vec3d::Ones();
  Vec3d origin_mm = Vec3d::Zero();
  Mat3d direction = Mat3d::Identity();  // world (LPS) direction of each index axis, as columns
  bool holds_density = false;  // the file says it holds hapvox densities (a writer's metadata)
  bool holds_labels = false;   // the file says it is a label map (hapvox's or NIfTI's intent)
  std::string sample_type;     // type name as normalised, e.g. "uint8", "int16", "float"
  double min_intensity = 0.0;
  double max_intensity = 0.0;
};

/// A density field's densities over its index box [0, dims), as a dense float volume with
/// its geometry (sample type "float").
RawVolume dense_intensity(const DensityField& field);

}  // namespace hapvox::engine::io
