#include "engine/io/raw_file.h"

#include <bit>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <system_error>
#include <vector>

#include "engine/errors.h"
#include "engine/io/payload.h"
#include "engine/io/text.h"

namespace hapvox::engine::io {
namespace {

constexpr const char* kExtension = ".raw";
constexpr const char* kSyntax =
    "FILE.raw:dims=NXxNYxNZ,type=T[,endian=little|big][,spacing_mm=SXxSYxSZ]"
    "[,origin_mm=OXxOYxOZ][,header_bytes=N]";

// Where the options begin (the ':' after ".raw"), or npos when the spec has none.
std::size_t options_colon(const std::string& spec) {
  const std::string name = lower(spec);
  const std::string marker = std::string(kExtension) + ":";
  const std::size_t at = name.find(marker);
  // ".raw" must end a file name, not be one ("dir/.raw:..." names no file).
  if (at == std::string::npos || at == 0 || name[at - 1] == '/') return std::string::npos;
  return at + marker.size() - 1;
}

std::vector<std::string> split(const std::string& text, char separator) {
  std::vector<std::string> parts;
  std::size_t begin = 0;
  while (true) {
    const std::size_t end = text.find(separator, begin);
    parts.push_back(text.substr(begin, end == std::string::npos ? std::string::npos : end - begin));
    if (end == std::string::npos) return parts;
    begin = end + 1;
  }
}

// "AxBxC" as three numbers.
Vec3d parse_triple(const std::string& spec, const std::string& key, const std::string& value) {
  const std::vector<std::string> parts = split(value, 'x');
  Vec3d out;
  bool ok = parts.size() == 3;
  for (std::size_t i = 0; ok && i < 3; ++i) ok = parse_double(parts[i], &out[static_cast<int>(i)]);
  if (!ok || !out.allFinite()) {
    throw InputError(spec, key + "=" + value + ": expected three finite numbers as AxBxC");
  }
  return out;
}

}  // namespace

std::string raw_data_file(const std::string& spec) {
  const std::size_t colon = options_colon(spec);
  if (colon != std::string::npos) return spec.substr(0, colon);
  const std::string name = lower(spec);
  return ends_with(name, kExtension) && name.size() > 4 && name[name.size() - 5] != '/' ? spec : "";
}

RawFileSpec parse_raw_spec(const std::string& spec) {
  RawFileSpec out;
  const std::size_t colon = options_colon(spec);
  if (colon == std::string::npos) {
    throw InputError(spec, std::string("a raw file needs its layout: ") + kSyntax);
  }
  out.path = spec.substr(0, colon);
  std::set<std::string> seen;
  for (const std::string& option : split(spec.substr(colon + 1), ',')) {
    const std::size_t equals = option.find('=');
    if (equals == std::string::npos) {
      throw InputError(spec, "option '" + option + "' is not key=value (" + kSyntax + ")");
    }
    const std::string key = trim(option.substr(0, equals));
    const std::string value = trim(option.substr(equals + 1));
    if (!seen.insert(key).second) throw InputError(spec, "option '" + key + "' given twice");
    if (key == "dims") {
      const Vec3d dims = parse_triple(spec, key, value);
      for (int i = 0; i < 3; ++i) {
        if (!(dims[i] >= 1.0 && dims[i] <= static_cast<double>(kMaxSamples)) ||
            dims[i] != std::floor(dims[i])) {
          throw InputError(spec, "dims=" + value + ": each size must be a whole number >= 1");
        }
      }
      if (dims.prod() > static_cast<double>(kMaxSamples)) {
        throw InputError(spec, "dims=" + value + ": more than 2^31 samples");
      }
      out.dims = dims.cast<int>();
    } else if (key == "type") {
      out.type = find_sample_type(lower(value));
      if (out.type == nullptr) {
        throw InputError(spec, "type=" + value +
                                   ": unknown sample type (int8, uint8, int16, uint16, int32, "
                                   "uint32, int64, uint64, float or double)");
      }
    } else if (key == "endian") {
      if (value != "little" && value != "big") {
        throw InputError(spec, "endian=" + value + ": expected little or big");
      }
      out.big_endian = value == "big";
    } else if (key == "spacing_mm") {
      out.spacing_mm = parse_triple(spec, key, value);
      if (!(out.spacing_mm.minCoeff() > 0.0)) {
        throw InputError(spec, "spacing_mm=" + value + ": spacings must be > 0");
      }
    } else if (key == "origin_mm") {
      out.origin_mm = parse_triple(spec, key, value);
    } else if (key == "header_bytes") {
      if (!parse_int(value, &out.header_bytes) || out.header_bytes < 0) {
        throw InputError(spec, "header_bytes=" + value + ": expected a whole number >= 0");
      }
    } else {
      throw InputError(spec, "unknown option '" + key +
                                 "' (dims, type, endian, spacing_mm, origin_mm, header_bytes)");
    }
  }
  if (!seen.contains("dims")) throw InputError(spec, std::string("dims= is missing: ") + kSyntax);
  if (!seen.contains("type")) throw InputError(spec, std::string("type= is missing: ") + kSyntax);
  return out;
}

RawVolume read_raw_file(const std::string& spec) {
  const RawFileSpec layout = parse_raw_spec(spec);
  std::error_code ec;
  const std::uintmax_t file_bytes = std::filesystem::file_size(layout.path, ec);
  std::ifstream in(layout.path, std::ios::binary);
  if (ec || !in || std::filesystem::is_directory(layout.path, ec)) {
    throw InputError(layout.path, "cannot open the raw file");
  }
  const std::uint64_t samples = static_cast<std::uint64_t>(layout.dims.x()) *
                                static_cast<std::uint64_t>(layout.dims.y()) *
                                static_cast<std::uint64_t>(layout.dims.z());
  const std::uint64_t needed =
      static_cast<std::uint64_t>(layout.header_bytes) + samples * layout.type->size;
  // Checked before anything is allocated: a wrong layout is the likely mistake, so say both.
  if (file_bytes != needed) {
    throw InputError(layout.path,
                     "holds " + std::to_string(file_bytes) + " bytes, but " +
                         std::to_string(layout.dims.x()) + "x" + std::to_string(layout.dims.y()) +
                         "x" + std::to_string(layout.dims.z()) + " samples of " +
                         layout.type->name + " after " + std::to_string(layout.header_bytes) +
                         " header bytes need " + std::to_string(needed));
  }
  const std::int64_t dims[3] = {layout.dims.x(), layout.dims.y(), layout.dims.z()};
  check_volume_budget(dims, layout.type->size, layout.type->name, layout.path);
  const std::vector<unsigned char> bytes =
      read_raw(in, layout.header_bytes, samples * layout.type->size, layout.path);
  RawVolume raw;
  raw.dims = layout.dims;
  raw.spacing_mm = layout.spacing_mm;
  raw.origin_mm = layout.origin_mm;
  raw.sample_type = layout.type->name;
  raw.intensity.resize(static_cast<std::size_t>(samples));
  const bool swap = layout.big_endian != (std::endian::native == std::endian::big);
  decode_samples(bytes, layout.type->type, swap, &raw.intensity, layout.path);
  set_min_max(&raw);
  return raw;
}

}  // namespace hapvox::engine::io
