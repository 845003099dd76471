#pragma once
// Headerless raw volumes: the samples alone, laid out as the spec naming the file says:
//
//   FILE.raw:dims=NXxNYxNZ,type=T[,endian=little|big][,spacing_mm=SXxSYxSZ]
//            [,origin_mm=OXxOYxOZ][,header_bytes=N]
//
// T is a sample type (int8, uint8, int16, uint16, int32, uint32, int64, uint64, float,
// double, or NRRD's spellings such as "short"); samples run x fastest, then y, then z.
// Defaults: little endian, 1 mm spacing, origin 0, no header bytes. The index axes are the
// world's (LPS) axes: a raw file carries no orientation. The file must hold exactly
// header_bytes plus the samples.

#include <cstdint>
#include <string>

#include "engine/io/raw_volume.h"
#include "engine/io/samples.h"

namespace hapvox::engine::io {

/// A raw file and the layout its spec gives.
struct RawFileSpec {
  std::string path;  // the file (the spec before its options)
  Vec3i dims = Vec3i::Zero();
  const SampleTypeInfo* type = nullptr;
  bool big_endian = false;
  Vec3d spacing_mm = Vec3d::Ones();
  Vec3d origin_mm = Vec3d::Zero();
  std::int64_t header_bytes = 0;
};

/// Parses a raw file's spec. Throws InputError(SPEC, ...) naming the option that is missing,
/// unknown, repeated or out of range (dims of at least 1 whose product is at most
/// kMaxSamples, spacings > 0, finite origins, header_bytes >= 0).
RawFileSpec parse_raw_spec(const std::string& spec);

/// The file a raw spec names ("" when `spec` is no raw spec): what it reads.
std::string raw_data_file(const std::string& spec);

/// Reads the samples a raw spec describes. Throws InputError(FILE, ...) when the file cannot
/// be opened or holds more or fewer bytes than the layout needs (both sizes named), and on
/// NaN or infinite floats.
RawVolume read_raw_file(const std::string& spec);

}  // namespace hapvox::engine::io
