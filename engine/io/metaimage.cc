#include "engine/io/metaimage.h"

#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include "engine/errors.h"
#include "engine/io/direction.h"
#include "engine/io/payload.h"
#include "engine/io/samples.h"
#include "engine/io/text.h"

namespace hapvox::engine::io {
namespace {

namespace fs = std::filesystem;

// MetaIO's element types (metaTypes.h): MET_LONG is 32 bits there, whatever `long` is.
const std::map<std::string, SampleType>& element_types() {
  static const std::map<std::string, SampleType> types = {
      {"MET_CHAR", SampleType::kInt8},       {"MET_UCHAR", SampleType::kUint8},
      {"MET_SHORT", SampleType::kInt16},     {"MET_USHORT", SampleType::kUint16},
      {"MET_INT", SampleType::kInt32},       {"MET_UINT", SampleType::kUint32},
      {"MET_LONG", SampleType::kInt32},      {"MET_ULONG", SampleType::kUint32},
      {"MET_LONG_LONG", SampleType::kInt64}, {"MET_ULONG_LONG", SampleType::kUint64},
      {"MET_FLOAT", SampleType::kFloat},     {"MET_DOUBLE", SampleType::kDouble},
  };
  return types;
}

const char* met_type_name(WrittenType type) {
  switch (type) {
    case WrittenType::float32:
      return "MET_FLOAT";
    case WrittenType::uint8:
      return "MET_UCHAR";
    case WrittenType::uint16:
      return "MET_USHORT";
    case WrittenType::int32:
      return "MET_INT";
  }
  return "";
}

struct MetaHeader {
  std::map<std::string, std::string> fields;  // lower-case key -> trimmed value
  std::streampos data_start = 0;              // just after the ElementDataFile line
};

// Header lines are "Key = Value"; ElementDataFile ends the header. A line longer than any
// header line, or a byte no text has, means this is not a MetaImage header.
MetaHeader read_meta_header(std::istream& in, const std::string& path) {
  constexpr std::size_t kMaxLine = 4096;
  constexpr int kMaxLines = 1000;
  MetaHeader header;
  std::string line;
  for (int count = 0;; ++count) {
    if (count > kMaxLines) throw InputError(path, "header has no ElementDataFile line");
    line.clear();
    for (int c; (c = in.get()) != EOF && c != '\n';) {
      if (line.size() >= kMaxLine || (c < 0x20 && c != '\t' && c != '\r')) {
        throw InputError(path, count == 0
                                   ? "not a MetaImage file (no 'Key = Value' header)"
                                   : "header line " + std::to_string(count + 1) + " is not text");
      }
      line.push_back(static_cast<char>(c));
    }
    if (!in && line.empty()) {
      throw InputError(path, count == 0 ? "empty file" : "header has no ElementDataFile line");
    }
    const std::string text = trim(line);
    if (text.empty()) continue;
    const auto eq = text.find('=');
    if (eq == std::string::npos || trim(text.substr(0, eq)).empty()) {
      throw InputError(path, count == 0 ? "not a MetaImage file (no 'Key = Value' header)"
                                        : "malformed header line '" + printable(text, 60) + "'");
    }
    const std::string key = lower(trim(text.substr(0, eq)));
    if (!header.fields.emplace(key, trim(text.substr(eq + 1))).second) {
      throw InputError(path, "field '" + trim(text.substr(0, eq)) + "' appears twice");
    }
    if (key == "elementdatafile") break;
  }
  header.data_start = in.tellg();
  return header;
}

const std::string* find(const MetaHeader& h, const std::string& key) {
  const auto it = h.fields.find(key);
  return it == h.fields.end() ? nullptr : &it->second;
}

const std::string& require(const MetaHeader& h, const std::string& key, const std::string& name,
                           const std::string& path) {
  const std::string* v = find(h, key);
  if (v == nullptr) throw InputError(path, "missing required field '" + name + "'");
  return *v;
}

std::vector<double> numbers(const std::string& text, std::size_t count, const std::string& name,
                            const std::string& path) {
  const auto parts = split_ws(text);
  std::vector<double> out(parts.size());
  bool ok = parts.size() == count;
  for (std::size_t i = 0; ok && i < parts.size(); ++i) {
    ok = parse_double(parts[i], &out[i]) && std::isfinite(out[i]);
  }
  if (!ok) {
    throw InputError(path, name + " must list " + std::to_string(count) + " finite numbers, got '" +
                               printable(text, 60) + "'");
  }
  return out;
}

bool flag(const MetaHeader& h, const std::string& key, const std::string& name,
          const std::string& path) {
  const std::string* v = find(h, key);
  if (v == nullptr) return false;
  const std::string value = lower(*v);
  if (value == "true" || value == "1") return true;
  if (value == "false" || value == "0") return false;
  throw InputError(path, name + " must be True or False, got '" + printable(*v, 40) + "'");
}

// The first of several spellings MetaIO accepts for one field.
const std::string* find_any(const MetaHeader& h, std::initializer_list<const char*> keys,
                            std::string* name) {
  for (const char* key : keys) {
    if (const std::string* v = find(h, lower(key))) {
      *name = key;
      return v;
    }
  }
  return nullptr;
}

struct DataSource {
  std::string file;  // "" when LOCAL
  bool compressed = false;
  std::int64_t header_size = 0;  // bytes skipped in a detached file; -1: data at its end
};

DataSource data_source(const MetaHeader& header, const std::string& path) {
  DataSource source;
  const std::string& name = require(header, "elementdatafile", "ElementDataFile", path);
  source.compressed = flag(header, "compresseddata", "CompressedData", path);
  if (lower(name) != "local") {
    if (lower(name).rfind("list", 0) == 0 || name.find('%') != std::string::npos ||
        split_ws(name).size() != 1) {
      throw InputError(path, "multi-file data ('ElementDataFile = " + printable(name, 60) +
                                 "') is not supported");
    }
    const fs::path file(name);
    source.file = (file.is_relative() ? fs::path(path).parent_path() / file : file).string();
    if (const std::string* v = find(header, "headersize")) {
      if (!parse_int(*v, &source.header_size) || source.header_size < -1) {
        throw InputError(path, "HeaderSize must be a non-negative integer or -1, got '" +
                                   printable(*v, 40) + "'");
      }
    }
  }
  return source;
}

}  // namespace

std::string metaimage_data_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in || fs::is_directory(path)) throw InputError(path, "cannot open file");
  return data_source(read_meta_header(in, path), path).file;
}

RawVolume read_metaimage(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in || fs::is_directory(path)) throw InputError(path, "cannot open file");
  const MetaHeader header = read_meta_header(in, path);

  if (const std::string* type = find(header, "objecttype"); type && lower(*type) != "image") {
    throw InputError(path, "ObjectType '" + printable(*type, 40) + "' is not an Image");
  }
  const std::string& ndims = require(header, "ndims", "NDims", path);
  if (trim(ndims) != "3") {
    throw InputError(
        path, "NDims " + printable(ndims, 20) + " is not supported (only 3-D scalar volumes are)");
  }
  if (const std::string* channels = find(header, "elementnumberofchannels");
      channels && trim(*channels) != "1") {
    throw InputError(path, "ElementNumberOfChannels " + printable(*channels, 20) +
                               " is not supported (only scalar volumes are)");
  }
  if (const std::string* binary = find(header, "binarydata");
      binary && !flag(header, "binarydata", "BinaryData", path)) {
    throw InputError(path, "ASCII data (BinaryData = False) is not supported");
  }

  RawVolume raw;
  const std::string& dim_text = require(header, "dimsize", "DimSize", path);
  const auto sizes = split_ws(dim_text);
  std::int64_t samples = 1;
  std::int64_t dims[3] = {};
  for (std::size_t i = 0; i < 3; ++i) {
    std::int64_t& s = dims[i];
    if (sizes.size() != 3 || !parse_int(sizes[i], &s) || s <= 0) {
      throw InputError(
          path, "DimSize must list 3 positive integers, got '" + printable(dim_text, 60) + "'");
    }
    if (s > kMaxSamples || samples * s > kMaxSamples) {
      throw InputError(
          path, "DimSize '" + printable(dim_text, 60) + "' is too large (over 2^31 samples)");
    }
    samples *= s;
    raw.dims[static_cast<int>(i)] = static_cast<int>(s);
  }

  const std::string& type_text = require(header, "elementtype", "ElementType", path);
  const auto type_it = element_types().find(trim(type_text));
  if (type_it == element_types().end()) {
    throw InputError(path, "unsupported ElementType '" + printable(type_text, 40) + "'");
  }
  const SampleTypeInfo& type = sample_type_info(type_it->second);
  raw.sample_type = type.name;
  check_volume_budget(dims, type.size, type.name, path);

  std::string name;
  if (const std::string* v = find_any(header, {"ElementSpacing", "ElementSize"}, &name)) {
    const auto s = numbers(*v, 3, name, path);
    raw.spacing_mm = Vec3d(s[0], s[1], s[2]);
    if (raw.spacing_mm.minCoeff() <= 0.0) {
      throw InputError(path, name + " must be positive, got '" + printable(*v, 60) + "'");
    }
  }
  if (const std::string* v = find_any(header, {"Offset", "Position", "Origin"}, &name)) {
    const auto o = numbers(*v, 3, name, path);
    raw.origin_mm = Vec3d(o[0], o[1], o[2]);
  }
  if (const std::string* v =
          find_any(header, {"TransformMatrix", "Rotation", "Orientation"}, &name)) {
    // Row i of the matrix as written is the world direction of index axis i (as ITK reads it).
    const auto m = numbers(*v, 9, name, path);
    for (int axis = 0; axis < 3; ++axis) {
      raw.direction.col(axis) = Vec3d(m[3 * axis], m[3 * axis + 1], m[3 * axis + 2]);
    }
    if (const std::string problem = direction_problem(raw.direction); !problem.empty()) {
      throw InputError(path, name + " is " + problem);
    }
  }
  if (const std::string* v = find(header, "anatomicalorientation")) {
    if (!orientation_code_valid(*v)) {
      throw InputError(path, "AnatomicalOrientation '" + printable(*v, 20) +
                                 "' is not three of R/L, A/P, I/S (or \?\?\?)");
    }
  }
  bool big_endian = false;
  if (find(header, "binarydatabyteordermsb") != nullptr) {
    big_endian = flag(header, "binarydatabyteordermsb", "BinaryDataByteOrderMSB", path);
  } else {
    big_endian = flag(header, "elementbyteordermsb", "ElementByteOrderMSB", path);
  }
  const bool swap = type.size > 1 && big_endian != (std::endian::native == std::endian::big);
  if (const std::string* content = find(header, "hapvoxcontent")) {
    raw.holds_density = lower(*content) == "density";
    raw.holds_labels = lower(*content) == "labels";
  }

  const DataSource source = data_source(header, path);
  std::ifstream detached;
  std::istream* data = &in;
  std::int64_t skip = 0;
  if (!source.file.empty()) {
    detached.open(source.file, std::ios::binary);
    if (!detached || fs::is_directory(source.file)) {
      throw InputError(path, "cannot open data file '" + source.file + "'");
    }
    data = &detached;
    skip = source.header_size;
  } else {
    in.clear();
    in.seekg(header.data_start);
  }
  const auto n_bytes = static_cast<std::uint64_t>(samples) * type.size;
  const std::vector<unsigned char> bytes =
      source.compressed ? read_gzip(*data, skip < 0 ? 0 : skip, n_bytes, path)
                        : read_raw(*data, skip, n_bytes, path);
  raw.intensity.resize(static_cast<std::size_t>(samples));
  decode_samples(bytes, type.type, swap, &raw.intensity, path);
  set_min_max(&raw);
  return raw;
}

std::string metaimage_written_data_file(const std::string& path) {
  if (lower(fs::path(path).extension().string()) != ".mhd") return "";
  return (fs::path(path).parent_path() / (fs::path(path).stem().string() + ".zraw")).string();
}

void write_metaimage(const DensityField& field, const std::string& path) {
  write_metaimage_volume(density_to_write(field), path);
}

void write_metaimage_volume(const WrittenVolume& volume, const std::string& path) {
  const std::vector<unsigned char> data =
      deflate_bytes(volume.bytes.data(), volume.bytes.size(), /*gzip=*/false);
  const std::string data_path = metaimage_written_data_file(path);
  const bool detached = !data_path.empty();
  const std::string data_name = fs::path(data_path).filename().string();

  std::ostringstream h;
  h.precision(17);
  const Vec3i& d = volume.dims;
  const Vec3d& s = volume.spacing_mm;
  const Vec3d& o = volume.origin_mm;
  const Mat3d& dir = volume.direction;
  h << "ObjectType = Image\nNDims = 3\nBinaryData = True\n"
    << "BinaryDataByteOrderMSB = " << (std::endian::native == std::endian::big ? "True" : "False")
    << "\nCompressedData = True\nCompressedDataSize = " << data.size() << "\nTransformMatrix =";
  for (int axis = 0; axis < 3; ++axis) {
    for (int c = 0; c < 3; ++c) h << " " << dir(c, axis);
  }
  h << "\nOffset = " << o.x() << " " << o.y() << " " << o.z() << "\nCenterOfRotation = 0 0 0\n"
    << "AnatomicalOrientation = " << orientation_code(dir) << "\n"
    << "ElementSpacing = " << s.x() << " " << s.y() << " " << s.z() << "\n"
    << "DimSize = " << d.x() << " " << d.y() << " " << d.z() << "\n"
    << "HapvoxContent = " << (volume.content == WrittenContent::labels ? "labels" : "density")
    << "\nElementNumberOfChannels = 1\nElementType = " << met_type_name(volume.type) << "\n"
    << "ElementDataFile = " << (detached ? data_name : "LOCAL") << "\n";
  const std::string text = h.str();
  if (detached) {
    write_file_atomically(data_path, {{data.data(), data.size()}});
    write_file_atomically(path, {{text.data(), text.size()}});
  } else {
    write_file_atomically(path, {{text.data(), text.size()}, {data.data(), data.size()}});
  }
}

}  // namespace hapvox::engine::io
