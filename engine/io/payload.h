#pragma once
// Reading a volume's payload bytes: raw, or gzip/zlib compressed. Sizes are checked before
// anything is allocated, so a corrupt header cannot make a reader allocate gigabytes.

#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <istream>
#include <string>
#include <vector>

#include "engine/density_field.h"
#include "engine/io/output_file.h"

namespace hapvox::engine::io {

/// Refuses a volume before anything is allocated when its samples, decoded as hapvox holds
/// them (4 bytes each, 8 for float64 files), would pass --max-input-mb (engine/input_limits.h):
/// InputError(path, "NX x NY x NZ TYPE samples take N MB decoded, over the limit of M MB
/// (raise it with --max-input-mb)"); `type_name` may be "" (a DICOM series').
void check_volume_budget(const std::int64_t (&dims)[3], std::size_t sample_bytes,
                         const std::string& type_name, const std::string& path);

/// Reads exactly `n` payload bytes of raw encoding after skipping `byte_skip` bytes.
/// byte_skip == -1 means the payload is the last n bytes of the stream. Throws
/// InputError(path, ...) when fewer or (byte_skip >= 0) more bytes follow.
std::vector<unsigned char> read_raw(std::istream& in, std::int64_t byte_skip, std::uint64_t n,
                                    const std::string& path);

/// Inflates a gzip (or zlib) stream, skipping `byte_skip` decompressed bytes first (as teem
/// does for compressed encodings); bytes after the end of the stream are ignored. Throws
/// InputError(path, ...) on corrupt, short or long data.
std::vector<unsigned char> read_gzip(std::istream& in, std::int64_t byte_skip, std::uint64_t n,
                                     const std::string& path);

/// The field's densities over its index box [0, dims), x fastest.
std::vector<float> dense_floats(const DensityField& field);

/// Deflates `size` bytes at level 6, with a gzip wrapper when `gzip` (NRRD, .nii.gz: tools
/// that insist on gzip), else a zlib one (MetaImage's CompressedData).
std::vector<unsigned char> deflate_bytes(const void* data, std::size_t size, bool gzip);

}  // namespace hapvox::engine::io
