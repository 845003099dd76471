#pragma once
// OpenVDB volumes (.vdb): Blender, Houdini and hapvox's own sculpted volumes.

#include <string>

#include "engine/density_field.h"
#include "engine/io/raw_volume.h"
#include "engine/io/written_volume.h"

namespace hapvox::engine::io {

/// Reads the float grid named "density" (or, failing that, the first float grid) of a
/// .vdb file. Voxel size and origin come from the grid's transform; dims from the
/// "hapvox_dims" metadata if present, else the active bounding box.
DensityField read_vdb(const std::string& path);

/// Writes the field as grid "density" with its transform and dims metadata.
void write_vdb(const DensityField& field, const std::string& path);

/// Writes a label map as an Int32 grid named "labels" (label 0 inactive), with the
/// transform and dims metadata write_vdb writes and hapvox_content "labels".
void write_vdb_labels(const WrittenVolume& volume, const std::string& path);

/// The samples of a .vdb: a file with a float grid reads as read_vdb's densities; one whose
/// only scalar grid is an Int32 grid (a label map) reads as its labels, sample type "int32".
RawVolume read_vdb_samples(const std::string& path);

}  // namespace hapvox::engine::io
