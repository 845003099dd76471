#pragma once
// MetaImage volumes (ITK, 3D Slicer, ParaView): .mha (header and data in one file) and .mhd
// (a text header naming its data file). Raw or zlib-compressed (CompressedData) data; the
// MET_ element types; ElementSpacing, Offset and TransformMatrix give the index-to-world
// affine in ITK's LPS frame (docs/formats.md).
//
// Hand-written: Debian packages MetaIO only inside ITK and VTK, hundreds of megabytes of
// libraries for a text header and a zlib stream.

#include <string>

#include "engine/density_field.h"
#include "engine/io/raw_volume.h"
#include "engine/io/written_volume.h"

namespace hapvox::engine::io {

/// Reads a 3-D scalar MetaImage. Throws InputError(PATH, ...) on any problem: a missing or
/// unreadable file, a header that is not MetaImage or lacks a required field, more than
/// one channel, a size over kMaxSamples (refused before anything is allocated), a
/// TransformMatrix that is not orthonormal, a short, long or corrupt payload, non-finite
/// samples.
RawVolume read_metaimage(const std::string& path);

/// The data file a .mhd header names (resolved against its folder), or "" for LOCAL data.
std::string metaimage_data_file(const std::string& path);

/// The data file write_metaimage writes beside a .mhd (NAME.zraw), or "" for a .mha.
std::string metaimage_written_data_file(const std::string& path);

/// Writes a density field as MetaImage: a .mha holds header and zlib-compressed float data;
/// a .mhd writes its data beside it as NAME.zraw. Spacing, offset and direction are kept;
/// the header says the file holds hapvox densities (HapvoxContent = density). Written to
/// PATH.partial then renamed.
void write_metaimage(const DensityField& field, const std::string& path);

/// Writes a volume the same way in its sample type (MET_FLOAT, MET_UCHAR, MET_USHORT or
/// MET_INT), HapvoxContent saying whether it holds densities or labels.
void write_metaimage_volume(const WrittenVolume& volume, const std::string& path);

}  // namespace hapvox::engine::io
