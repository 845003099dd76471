#pragma once
// NRRD volumes: .nrrd (attached header) and .nhdr (detached header); raw or gzip; any
// integer or float sample type; spacings or space directions.

#include <string>

#include "engine/density_field.h"
#include "engine/io/raw_volume.h"
#include "engine/io/written_volume.h"

namespace hapvox::engine::io {

/// Reads a NRRD volume (3-D, scalar). Throws InputError("PATH", "...") on any problem:
/// missing file, bad magic, unsupported/missing fields, wrong dimension, truncated or
/// corrupt payload, NaN or infinite samples, non-positive spacing.
RawVolume read_nrrd(const std::string& path);

/// The detached data file a NRRD header names ("data file: F", F resolved against the
/// header's folder as read_nrrd does), or "" when its data is attached (or multi-file).
/// Throws InputError on a file that is not a NRRD.
std::string nrrd_data_file(const std::string& path);

/// Writes a density field as a NRRD (float, gzip, attached header) with spacings and
/// origin, covering the index box [0, dims). Written to PATH.partial then renamed.
void write_nrrd(const DensityField& field, const std::string& path);

/// Writes a volume as a NRRD (its sample type, gzip, attached header, space directions and
/// origin in LPS); "hapvox_content:=density" or "labels" says what it holds.
void write_nrrd_volume(const WrittenVolume& volume, const std::string& path);

}  // namespace hapvox::engine::io
