#pragma once
// The clay block the engine tests press: density 1 filling index z < top_k over an n x n
// footprint, so its nominal surface (density 1/2 under trilinear interpolation) is the
// voxel face z = (top_k - 0.5) h.

#include "engine/density_field.h"

namespace hapvox::engine::fixtures {

/// dims_z: the volume's z extent in voxels (0: n, a cube).
inline DensityField make_block(int n, int top_k, const Vec3d& voxel_mm, int dims_z = 0) {
  initialize_openvdb();
  auto grid = openvdb::FloatGrid::create(0.0f);
  grid->tree().fill(
      openvdb::CoordBBox(openvdb::Coord(0, 0, 0), openvdb::Coord(n - 1, n - 1, top_k - 1)), 1.0f,
      true);
  grid->tree().voxelizeActiveTiles();
  return DensityField(grid, voxel_mm, Vec3d::Zero(), Vec3i(n, n, dims_z > 0 ? dims_z : n));
}

}  // namespace hapvox::engine::fixtures
