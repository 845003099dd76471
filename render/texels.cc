#include "render/texels.h"

#include <algorithm>
#include <cmath>

namespace hapvox::render {
namespace {

std::uint8_t encode_unit(double v) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(0.5 + 0.5 * v, 0.0, 1.0) * 255.0));
}

}  // namespace

float DenseVolume::at_clamped(int x, int y, int z) const {
  x = std::clamp(x, 0, dims.x() - 1);
  y = std::clamp(y, 0, dims.y() - 1);
  z = std::clamp(z, 0, dims.z() - 1);
  return density[index(x, y, z)];
}

DenseVolume dense_copy(const engine::DensityField& field) {
  DenseVolume volume;
  volume.dims = field.dims();
  volume.voxel_mm = field.voxel_size_mm();
  // The renderer draws the volume's grid frame (engine/density_field.h).
  volume.lo_mm = field.grid_min_mm();
  volume.hi_mm = field.grid_max_mm();
  volume.density.assign(volume.voxel_count(), 0.0f);
  // Leaf-wise copy of the active voxels inside [0, dims).
  for (auto leaf = field.grid().tree().cbeginLeaf(); leaf; ++leaf) {
    for (auto v = leaf->cbeginValueOn(); v; ++v) {
      const openvdb::Coord c = v.getCoord();
      if (c.x() < 0 || c.y() < 0 || c.z() < 0 || c.x() >= volume.dims.x() ||
          c.y() >= volume.dims.y() || c.z() >= volume.dims.z()) {
        continue;
      }
      volume.density[volume.index(c.x(), c.y(), c.z())] = std::clamp(*v, 0.0f, 1.0f);
    }
  }
  return volume;
}

Eigen::Vector3d central_gradient(const DenseVolume& v, int x, int y, int z) {
  return {(v.at_clamped(x + 1, y, z) - v.at_clamped(x - 1, y, z)) / (2.0 * v.voxel_mm.x()),
          (v.at_clamped(x, y + 1, z) - v.at_clamped(x, y - 1, z)) / (2.0 * v.voxel_mm.y()),
          (v.at_clamped(x, y, z + 1) - v.at_clamped(x, y, z - 1)) / (2.0 * v.voxel_mm.z())};
}

void encode_texel(const Eigen::Vector3d& gradient, float density, std::uint8_t* rgba) {
  const double norm = gradient.norm();
  if (norm > 1e-6) {
    const Eigen::Vector3d n = gradient / norm;
    rgba[0] = encode_unit(n.x()), rgba[1] = encode_unit(n.y()), rgba[2] = encode_unit(n.z());
  } else {
    rgba[0] = rgba[1] = rgba[2] = 128;  // no direction: unshaded
  }
  rgba[3] = static_cast<std::uint8_t>(std::lround(std::clamp(density, 0.0f, 1.0f) * 255.0f));
}

}  // namespace hapvox::render
