#pragma once
// Sample types a volume file may store, and their decoding into float intensities.

#include <cstddef>
#include <string>
#include <vector>

#include "engine/io/raw_volume.h"

namespace hapvox::engine::io {

enum class SampleType {
  kInt8,
  kUint8,
  kInt16,
  kUint16,
  kInt32,
  kUint32,
  kInt64,
  kUint64,
  kFloat,
  kDouble
};

struct SampleTypeInfo {
  SampleType type;
  const char* name;  // normalised name reported in RawVolume::sample_type
  std::size_t size;
};

/// The sample type a NRRD-style spelling names ("unsigned short", "uint16", "int16_t", ...;
/// lower case, single spaces), or nullptr.
const SampleTypeInfo* find_sample_type(const std::string& spelling);

/// The size and normalised name of `type`.
const SampleTypeInfo& sample_type_info(SampleType type);

/// Decodes out->size() samples of `type` from `bytes` (byte-swapped when `swap`) into
/// floats. Throws InputError(path, ...) on NaN or infinite floats and on doubles beyond
/// float range.
void decode_samples(const std::vector<unsigned char>& bytes, SampleType type, bool swap,
                    std::vector<float>* out, const std::string& path);

/// Sets raw->min_intensity and max_intensity from its samples.
void set_min_max(RawVolume* raw);

}  // namespace hapvox::engine::io
