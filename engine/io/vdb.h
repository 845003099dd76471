#pragma once
// OpenVDB volumes (.vdb): Blender, Houdini and hapvox's own sculpted volumes.

#include <string>

#include "engine/density_field.h"

namespace hapvox::engine::io {

/// Reads the float grid named "density" (or, failing that, the first float grid) of a
/// .vdb file. Voxel size and origin come from the grid's transform; dims from the
/// "hapvox_dims" metadata if present, else the active bounding box.
DensityField read_vdb(const std::string& path);

/// Writes the field as grid "density" with its transform and dims metadata.
void write_vdb(const DensityField& field, const std::string& path);

}  // namespace hapvox::engine::io
