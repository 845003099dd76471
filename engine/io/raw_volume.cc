#include "engine/io/raw_volume.h"

#include <algorithm>
#include <cstddef>

namespace hapvox::engine::io {

RawVolume dense_intensity(const DensityField& field) {
  RawVolume raw;
  raw.dims = field.dims();
  raw.spacing_mm = field.voxel_size_mm();
  raw.origin_mm = field.origin_mm();
  raw.direction = field.direction();
  raw.sample_type = "float";
  raw.intensity.resize(static_cast<std::size_t>(raw.dims.x()) *
                       static_cast<std::size_t>(raw.dims.y()) *
                       static_cast<std::size_t>(raw.dims.z()));
  auto accessor = field.grid().getConstAccessor();
  std::size_t i = 0;
  for (int z = 0; z < raw.dims.z(); ++z) {
    for (int y = 0; y < raw.dims.y(); ++y) {
      for (int x = 0; x < raw.dims.x(); ++x) {
        raw.intensity[i++] = accessor.getValue(openvdb::Coord(x, y, z));
      }
    }
  }
  const auto [lo, hi] = std::minmax_element(raw.intensity.begin(), raw.intensity.end());
  raw.min_intensity = *lo;
  raw.max_intensity = *hi;
  return raw;
}

}  // namespace hapvox::engine::io
