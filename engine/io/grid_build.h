#pragma once
// Building a sparse density grid from a dense function of the voxel index.

#include <functional>

#include "engine/density_field.h"

namespace hapvox::engine::io {

/// Fills a grid from density(i, j, k) over [0, dims), one leaf-sized block at a time so only
/// blocks with material allocate leaves. Densities <= 0 stay inactive background.
openvdb::FloatGrid::Ptr build_grid(const Vec3i& dims,
                                   const std::function<float(int, int, int)>& density);

}  // namespace hapvox::engine::io
