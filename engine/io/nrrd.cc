#include "engine/io/nrrd.h"

#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <system_error>
#include <vector>

#include <zlib.h>

#include "engine/check.h"
#include "engine/errors.h"
#include "engine/io/direction.h"
#include "engine/io/payload.h"
#include "engine/io/samples.h"
#include "engine/io/text.h"

namespace hapvox::engine::io {
namespace {

namespace fs = std::filesystem;

// A header's text in a message: in quotes, printable (a NUL or a control byte as \xNN, the
// whole length: a value may hold a NUL where a C string would stop), cut short.
std::string quoted_value(const std::string& s, std::size_t max_len = 60) {
  return "'" + hapvox::printable(s, max_len) + "'";
}

struct NrrdHeader {
  std::map<std::string, std::string> fields;  // lower-case field name -> trimmed value
  std::map<std::string, std::string> values;  // key:=value pairs, key as written
  bool has_blank_line = false;                // attached data may follow
  std::streampos data_start = 0;              // stream position just after the header
};

NrrdHeader read_nrrd_header(std::istream& in, const std::string& path) {
  NrrdHeader header;
  // Check the magic before any getline so a large binary file is not slurped as one line.
  char magic[8] = {};
  in.read(magic, 8);
  const std::string magic_str(magic, static_cast<std::size_t>(in.gcount()));
  if (magic_str.size() < 8 || magic_str.compare(0, 7, "NRRD000") != 0 ||
      !std::isdigit(static_cast<unsigned char>(magic_str[7]))) {
    throw InputError(
        path, "not a NRRD file (bad magic " + quoted_value(magic_str) + ", expected NRRD000N)");
  }
  std::string line;
  std::getline(in, line);
  if (!trim(line).empty()) {
    throw InputError(path,
                     "not a NRRD file (bad magic line " + quoted_value(magic_str + line) + ")");
  }
  constexpr std::size_t kMaxHeaderLines = 10000;
  for (std::size_t count = 0; std::getline(in, line); ++count) {
    if (count > kMaxHeaderLines) throw InputError(path, "header too long (no blank line)");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) {
      header.has_blank_line = true;
      break;
    }
    if (line[0] == '#') continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos) {
      throw InputError(path, "malformed header line " + quoted_value(line));
    }
    if (colon + 1 < line.size() && line[colon + 1] == '=') {  // key:=value pair
      header.values[line.substr(0, colon)] = line.substr(colon + 2);
      continue;
    }
    std::string key = lower(trim(line.substr(0, colon)));
    // NRRD spells some fields two ways.
    if (key == "datafile") key = "data file";
    if (key == "lineskip") key = "line skip";
    if (key == "byteskip") key = "byte skip";
    if (key == "centerings") key = "centers";
    if (!header.fields.emplace(key, trim(line.substr(colon + 1))).second) {
      throw InputError(path, "field " + quoted_value(key) + " appears twice");
    }
  }
  header.data_start = in.tellg();
  return header;
}

const std::string* find_field(const NrrdHeader& h, const std::string& key) {
  const auto it = h.fields.find(key);
  return it == h.fields.end() ? nullptr : &it->second;
}

const std::string& require_field(const NrrdHeader& h, const std::string& key,
                                 const std::string& path) {
  const std::string* v = find_field(h, key);
  if (v == nullptr) throw InputError(path, "missing required field " + quoted_value(key));
  return *v;
}

// Parses "(x,y,z)" into three doubles.
bool parse_vector3(const std::string& text, Vec3d* out) {
  const std::string t = trim(text);
  if (t.size() < 2 || t.front() != '(' || t.back() != ')') return false;
  std::string inner = t.substr(1, t.size() - 2);
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (true) {
    const auto comma = inner.find(',', start);
    parts.push_back(trim(inner.substr(start, comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (parts.size() != 3) return false;
  for (int i = 0; i < 3; ++i) {
    if (!parse_double(parts[static_cast<std::size_t>(i)], &(*out)[i])) return false;
  }
  return true;
}

// "space directions: (a,b,c) (d,e,f) none" -> the parenthesised groups and "none"s.
std::vector<std::string> split_vectors(const std::string& text) {
  std::vector<std::string> out;
  std::size_t i = 0;
  while (i < text.size()) {
    if (std::isspace(static_cast<unsigned char>(text[i]))) {
      ++i;
    } else if (text[i] == '(') {
      const auto close = text.find(')', i);
      if (close == std::string::npos) {
        out.push_back(text.substr(i));
        break;
      }
      out.push_back(text.substr(i, close - i + 1));
      i = close + 1;
    } else {
      auto end = i;
      while (end < text.size() && !std::isspace(static_cast<unsigned char>(text[end]))) ++end;
      out.push_back(text.substr(i, end - i));
      i = end;
    }
  }
  return out;
}

}  // namespace

std::string nrrd_data_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in || fs::is_directory(path)) throw InputError(path, "cannot open file");
  const NrrdHeader header = read_nrrd_header(in, path);
  const std::string* data_file = find_field(header, "data file");
  if (data_file == nullptr || data_file->rfind("LIST", 0) == 0 ||
      data_file->find('%') != std::string::npos || split_ws(*data_file).size() != 1) {
    return "";
  }
  const fs::path file(*data_file);
  return (file.is_relative() ? fs::path(path).parent_path() / file : file).string();
}

RawVolume read_nrrd(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in || fs::is_directory(path)) throw InputError(path, "cannot open file");
  const NrrdHeader header = read_nrrd_header(in, path);

  const std::string type_text = lower(require_field(header, "type", path));
  const std::string type_norm = [&] {
    std::string joined;
    for (const auto& tok : split_ws(type_text)) joined += (joined.empty() ? "" : " ") + tok;
    return joined;
  }();
  const SampleTypeInfo* type_found = find_sample_type(type_norm);
  if (type_found == nullptr) {
    throw InputError(path, "unsupported sample type " + quoted_value(type_text));
  }
  const SampleTypeInfo type = *type_found;

  const std::string& dim_text = require_field(header, "dimension", path);
  std::int64_t dimension = 0;
  if (!parse_int(dim_text, &dimension)) {
    throw InputError(path, "bad dimension " + quoted_value(dim_text));
  }
  if (dimension != 3) {
    throw InputError(path,
                     "dimension " + dim_text + " is not supported (only 3-D scalar volumes are)");
  }

  RawVolume raw;
  raw.sample_type = type.name;
  const std::string& sizes_text = require_field(header, "sizes", path);
  const auto sizes = split_ws(sizes_text);
  if (sizes.size() != 3)
    throw InputError(path, "sizes must list 3 values, got " + quoted_value(sizes_text));
  std::int64_t samples = 1;
  std::int64_t dims[3] = {};
  for (int i = 0; i < 3; ++i) {
    std::int64_t& s = dims[i];
    if (!parse_int(sizes[static_cast<std::size_t>(i)], &s) || s <= 0) {
      throw InputError(path, "sizes must be positive integers, got " + quoted_value(sizes_text));
    }
    if (s > kMaxSamples || samples * s > kMaxSamples) {
      throw InputError(path,
                       "sizes " + quoted_value(sizes_text) + " are too large (over 2^31 samples)");
    }
    samples *= s;
    raw.dims[i] = static_cast<int>(s);
  }
  check_volume_budget(dims, type.size, type.name, path);

  if (const std::string* kinds = find_field(header, "kinds")) {
    for (const auto& kind : split_ws(lower(*kinds))) {
      if (kind != "domain" && kind != "space" && kind != "none" && kind != "???") {
        throw InputError(path, "axis kind " + quoted_value(kind) +
                                   " is not supported (only scalar volumes with 3 spatial "
                                   "axes are)");
      }
    }
  }

  // Spacing: space directions (vector norms) win over spacings; default 1 mm.
  if (const std::string* dirs = find_field(header, "space directions")) {
    const auto vecs = split_vectors(*dirs);
    if (vecs.size() != 3) {
      throw InputError(path, "space directions must give 3 vectors, got " + quoted_value(*dirs));
    }
    for (int i = 0; i < 3; ++i) {
      Vec3d v;
      if (!parse_vector3(vecs[static_cast<std::size_t>(i)], &v)) {
        throw InputError(path, "bad space direction " +
                                   quoted_value(vecs[static_cast<std::size_t>(i)]) +
                                   " (expected (x,y,z))");
      }
      raw.spacing_mm[i] = v.norm();
      if (raw.spacing_mm[i] > 0.0) raw.direction.col(i) = v / raw.spacing_mm[i];
    }
    if (const std::string problem = direction_problem(raw.direction); !problem.empty()) {
      throw InputError(path, "space directions are " + problem);
    }
  } else if (const std::string* spacings = find_field(header, "spacings")) {
    const auto parts = split_ws(*spacings);
    if (parts.size() != 3) {
      throw InputError(path, "spacings must list 3 values, got " + quoted_value(*spacings));
    }
    for (int i = 0; i < 3; ++i) {
      if (!parse_double(parts[static_cast<std::size_t>(i)], &raw.spacing_mm[i])) {
        throw InputError(path, "bad spacings " + quoted_value(*spacings));
      }
    }
  }
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(raw.spacing_mm[i]) || raw.spacing_mm[i] <= 0.0) {
      std::ostringstream msg;
      msg << "spacing must be positive and finite, got " << raw.spacing_mm[i] << " on axis " << i;
      throw InputError(path, msg.str());
    }
  }
  if (const std::string* origin = find_field(header, "space origin")) {
    if (!parse_vector3(*origin, &raw.origin_mm) || !raw.origin_mm.allFinite()) {
      throw InputError(path, "bad space origin " + quoted_value(*origin) + " (expected (x,y,z))");
    }
  }
  if (const std::string* space = find_field(header, "space")) {
    // Into LPS: a RAS vector (x right, y anterior) is (-x, -y, z) in LPS, a LAS one (x, -y, z).
    const std::string s = lower(*space);
    Vec3d flip = Vec3d::Ones();
    if (s == "right-anterior-superior" || s == "ras") {
      flip = Vec3d(-1, -1, 1);
    } else if (s == "left-anterior-superior" || s == "las") {
      flip = Vec3d(1, -1, 1);
    } else if (s != "left-posterior-superior" && s != "lps" && s != "scanner-xyz" &&
               s != "3d-right-handed" && s != "3d-left-handed") {
      throw InputError(path, "space " + quoted_value(*space) +
                                 " is not supported (expected a 3-D space such as "
                                 "left-posterior-superior or right-anterior-superior)");
    }
    raw.direction = flip.asDiagonal() * raw.direction;
    raw.origin_mm = flip.cwiseProduct(raw.origin_mm);
  }
  if (const auto it = header.values.find("hapvox_content"); it != header.values.end()) {
    raw.holds_density = trim(it->second) == "density";
    raw.holds_labels = trim(it->second) == "labels";
  }

  const std::string encoding = lower(require_field(header, "encoding", path));
  const bool gzip = encoding == "gzip" || encoding == "gz";
  if (!gzip && encoding != "raw") {
    throw InputError(path,
                     "unsupported encoding " + quoted_value(encoding) + " (expected raw or gzip)");
  }

  bool swap = false;
  if (type.size > 1) {
    const std::string* endian = find_field(header, "endian");
    if (endian == nullptr) throw InputError(path, "missing required field 'endian'");
    const std::string e = lower(*endian);
    if (e != "little" && e != "big") {
      throw InputError(path, "bad endian " + quoted_value(*endian) + " (expected little or big)");
    }
    swap = (e == "big") != (std::endian::native == std::endian::big);
  }

  std::int64_t line_skip = 0;
  std::int64_t byte_skip = 0;
  if (const std::string* v = find_field(header, "line skip")) {
    if (!parse_int(*v, &line_skip) || line_skip < 0) {
      throw InputError(path, "line skip must be a non-negative integer, got " + quoted_value(*v));
    }
  }
  if (const std::string* v = find_field(header, "byte skip")) {
    if (!parse_int(*v, &byte_skip) || byte_skip < -1) {
      throw InputError(path,
                       "byte skip must be a non-negative integer (or -1), got " + quoted_value(*v));
    }
  }

  // Data source: a detached file, else what follows the header's blank line.
  std::ifstream detached;
  std::istream* data = &in;
  if (const std::string* data_file = find_field(header, "data file")) {
    if (data_file->rfind("LIST", 0) == 0 || data_file->find('%') != std::string::npos ||
        split_ws(*data_file).size() != 1) {
      throw InputError(
          path, "multi-file data (data file: " + quoted_value(*data_file) + ") is not supported");
    }
    fs::path file(*data_file);
    if (file.is_relative()) file = fs::path(path).parent_path() / file;
    detached.open(file, std::ios::binary);
    if (!detached || fs::is_directory(file)) {
      throw InputError(path, "cannot open data file " + quoted_value(file.string(), 200));
    }
    data = &detached;
  } else if (!header.has_blank_line) {
    throw InputError(path, "no data: the header has no 'data file' field and no attached data");
  } else {
    in.seekg(header.data_start);
  }
  for (std::int64_t i = 0; i < line_skip; ++i) {
    std::string skipped;
    if (!std::getline(*data, skipped)) {
      throw InputError(path, "line skip " + std::to_string(line_skip) + " runs past the end");
    }
  }

  const auto n_bytes = static_cast<std::uint64_t>(samples) * type.size;
  const std::vector<unsigned char> bytes =
      gzip ? read_gzip(*data, byte_skip, n_bytes, path) : read_raw(*data, byte_skip, n_bytes, path);

  raw.intensity.resize(static_cast<std::size_t>(samples));
  decode_samples(bytes, type.type, swap, &raw.intensity, path);
  set_min_max(&raw);
  return raw;
}

void write_nrrd(const DensityField& field, const std::string& path) {
  write_nrrd_volume(density_to_write(field), path);
}

void write_nrrd_volume(const WrittenVolume& volume, const std::string& path) {
  // gzip wrapper so other tools that insist on gzip, not zlib, can read it.
  const std::vector<unsigned char> compressed =
      deflate_bytes(volume.bytes.data(), volume.bytes.size(), /*gzip=*/true);

  // Space directions rather than spacings: NRRD forbids "space origin" without a space,
  // and teem/Slicer/ITK reject spacings alongside one.
  std::ostringstream header;
  header.precision(17);
  const bool labels = volume.content == WrittenContent::labels;
  const Vec3i& dims = volume.dims;
  const Vec3d& s = volume.spacing_mm;
  const Vec3d& o = volume.origin_mm;
  header << "NRRD0004\n"
         << (labels ? "# written by hapvox: a label map (0 is background)\n"
                    : "# written by hapvox: density in [0, 1]\n")
         << "type: " << nrrd_type_name(volume.type) << "\n"
         << "dimension: 3\n"
         << "space: left-posterior-superior\n"
         << "sizes: " << dims.x() << " " << dims.y() << " " << dims.z() << "\n"
         << "space directions:";
  for (int a = 0; a < 3; ++a) {
    const Vec3d step = volume.direction.col(a) * s[a];
    header << " (" << step.x() << "," << step.y() << "," << step.z() << ")";
  }
  header << "\n"
         << "kinds: domain domain domain\n"
         << "endian: " << (std::endian::native == std::endian::big ? "big" : "little") << "\n"
         << "encoding: gzip\n"
         << "space origin: (" << o.x() << "," << o.y() << "," << o.z() << ")\n"
         << "hapvox_content:=" << (labels ? "labels" : "density") << "\n\n";

  const std::string h = header.str();
  write_file_atomically(path, {{h.data(), h.size()}, {compressed.data(), compressed.size()}});
}

}  // namespace hapvox::engine::io
