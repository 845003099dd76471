#pragma once
// Reading a volume's payload bytes: raw, or gzip/zlib compressed. Sizes are checked before
// anything is allocated, so a corrupt header cannot make a reader allocate gigabytes.

#include <cstdint>
#include <istream>
#include <string>
#include <vector>

namespace hapvox::engine::io {

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

}  // namespace hapvox::engine::io
