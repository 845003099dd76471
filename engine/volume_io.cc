#include "engine/volume_io.h"

#include <fcntl.h>
#include <openvdb/io/File.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>

#include <cerrno>
#include <csignal>
#include <cstdio>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include "engine/check.h"
#include "engine/errors.h"

namespace hapvox::engine {
namespace {

namespace fs = std::filesystem;

// Volumes larger than this many samples are almost surely a corrupt header (and would not
// fit our int indexing anyway).
constexpr std::int64_t kMaxSamples = std::int64_t{1} << 31;

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return "";
  const auto last = s.find_last_not_of(" \t\r\n");
  return s.substr(first, last - first + 1);
}

std::vector<std::string> split_ws(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> out;
  for (std::string tok; in >> tok;) out.push_back(tok);
  return out;
}

// Whole-token parses: "12abc" is not a number.
bool parse_int(const std::string& s, std::int64_t* out) {
  const char* end = s.data() + s.size();
  auto [ptr, ec] = std::from_chars(s.data(), end, *out);
  return ec == std::errc() && ptr == end && !s.empty();
}

bool parse_double(const std::string& s, double* out) {
  const char* begin = s.data();
  const char* end = s.data() + s.size();
  if (begin != end && *begin == '+') ++begin;  // from_chars rejects a leading '+'
  auto [ptr, ec] = std::from_chars(begin, end, *out);
  return ec == std::errc() && ptr == end && begin != end;
}

// Printable excerpt of possibly binary text, for error messages.
std::string printable(const std::string& s, std::size_t max_len = 40) {
  std::string out;
  for (char c : s.substr(0, max_len)) {
    out += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  }
  if (s.size() > max_len) out += "...";
  return out;
}

// ---------------------------------------------------------------------------------------
// NRRD reading.

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

const std::map<std::string, SampleTypeInfo>& sample_type_table() {
  static const auto* table = [] {
    auto* t = new std::map<std::string, SampleTypeInfo>;
    auto add = [t](SampleTypeInfo info, std::initializer_list<const char*> spellings) {
      for (const char* s : spellings) (*t)[s] = info;
    };
    add({SampleType::kInt8, "int8", 1}, {"signed char", "int8", "int8_t"});
    add({SampleType::kUint8, "uint8", 1}, {"uchar", "unsigned char", "uint8", "uint8_t"});
    add({SampleType::kInt16, "int16", 2},
        {"short", "short int", "signed short", "signed short int", "int16", "int16_t"});
    add({SampleType::kUint16, "uint16", 2},
        {"ushort", "unsigned short", "unsigned short int", "uint16", "uint16_t"});
    add({SampleType::kInt32, "int32", 4}, {"int", "signed int", "int32", "int32_t"});
    add({SampleType::kUint32, "uint32", 4}, {"uint", "unsigned int", "uint32", "uint32_t"});
    add({SampleType::kInt64, "int64", 8},
        {"longlong", "long long", "long long int", "signed long long", "signed long long int",
         "int64", "int64_t"});
    add({SampleType::kUint64, "uint64", 8},
        {"ulonglong", "unsigned long long", "unsigned long long int", "uint64", "uint64_t"});
    add({SampleType::kFloat, "float", 4}, {"float"});
    add({SampleType::kDouble, "double", 8}, {"double"});
    return t;
  }();
  return *table;
}

struct NrrdHeader {
  std::map<std::string, std::string> fields;  // lower-case field name -> trimmed value
  bool has_blank_line = false;                // attached data may follow
  std::streampos data_start = 0;              // stream position just after the header
};

NrrdHeader read_header(std::istream& in, const std::string& path) {
  NrrdHeader header;
  // Check the magic before any getline so a large binary file is not slurped as one line.
  char magic[8] = {};
  in.read(magic, 8);
  const std::string magic_str(magic, static_cast<std::size_t>(in.gcount()));
  if (magic_str.size() < 8 || magic_str.compare(0, 7, "NRRD000") != 0 ||
      !std::isdigit(static_cast<unsigned char>(magic_str[7]))) {
    throw InputError(
        path, "not a NRRD file (bad magic '" + printable(magic_str) + "', expected NRRD000N)");
  }
  std::string line;
  std::getline(in, line);
  if (!trim(line).empty()) {
    throw InputError(path,
                     "not a NRRD file (bad magic line '" + printable(magic_str + line) + "')");
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
      throw InputError(path, "malformed header line '" + printable(line) + "'");
    }
    if (colon + 1 < line.size() && line[colon + 1] == '=') continue;  // key:=value pair
    std::string key = lower(trim(line.substr(0, colon)));
    // NRRD spells some fields two ways.
    if (key == "datafile") key = "data file";
    if (key == "lineskip") key = "line skip";
    if (key == "byteskip") key = "byte skip";
    if (key == "centerings") key = "centers";
    if (!header.fields.emplace(key, trim(line.substr(colon + 1))).second) {
      throw InputError(path, "field '" + key + "' appears twice");
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
  if (v == nullptr) throw InputError(path, "missing required field '" + key + "'");
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

template <typename T>
T load_sample(const unsigned char* p, bool swap) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, p, sizeof(T));
  if (swap) std::reverse(bytes, bytes + sizeof(T));
  T v;
  std::memcpy(&v, bytes, sizeof(T));
  return v;
}

template <typename T>
void convert_samples(const std::vector<unsigned char>& bytes, bool swap, std::vector<float>* out,
                     const std::string& path) {
  const std::size_t n = out->size();
  bool non_finite = false;
  bool out_of_range = false;
  for (std::size_t i = 0; i < n; ++i) {
    const T v = load_sample<T>(bytes.data() + i * sizeof(T), swap);
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(v)) non_finite = true;
      if constexpr (sizeof(T) > sizeof(float)) {
        if (std::abs(v) > std::numeric_limits<float>::max()) out_of_range = true;
      }
    }
    (*out)[i] = static_cast<float>(v);
  }
  if (non_finite) throw InputError(path, "float data contains NaN or infinite values");
  if (out_of_range) throw InputError(path, "double data contains values beyond float range");
}

std::string truncated(std::uint64_t expected, std::uint64_t got) {
  return "truncated data: expected " + std::to_string(expected) + " bytes, got " +
         std::to_string(got);
}

// Reads exactly `n` payload bytes of raw encoding. byte_skip == -1 means the payload is the
// last n bytes of the file. Sizes are checked before allocating, so a corrupt header cannot
// make us allocate gigabytes.
std::vector<unsigned char> read_raw(std::istream& in, std::int64_t byte_skip, std::uint64_t n,
                                    const std::string& path) {
  const auto pos = in.tellg();
  in.seekg(0, std::ios::end);
  const auto end = in.tellg();
  std::uint64_t available = static_cast<std::uint64_t>(end - pos);
  if (byte_skip == -1) {
    if (available < n) throw InputError(path, truncated(n, available));
    in.seekg(end - static_cast<std::streamoff>(n));
  } else {
    const auto skip = static_cast<std::uint64_t>(byte_skip);
    available = available > skip ? available - skip : 0;
    if (available < n) throw InputError(path, truncated(n, available));
    // Extra bytes mean the header's sizes or type do not match the data.
    if (available > n) {
      throw InputError(path, "too much data: expected " + std::to_string(n) + " bytes, got " +
                                 std::to_string(available));
    }
    in.seekg(pos + static_cast<std::streamoff>(skip));
  }
  std::vector<unsigned char> bytes(n);
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(n));
  const auto got = static_cast<std::uint64_t>(in.gcount());
  if (got < n) throw InputError(path, truncated(n, got));
  return bytes;
}

// Inflates a gzip (or zlib) stream, skipping `byte_skip` decompressed bytes first (as teem
// does for compressed encodings). Bytes after the end of the gzip stream are ignored.
std::vector<unsigned char> read_gzip(std::istream& in, std::int64_t byte_skip, std::uint64_t n,
                                     const std::string& path) {
  if (byte_skip < 0) throw InputError(path, "byte skip -1 is only allowed with raw encoding");
  const auto skip = static_cast<std::uint64_t>(byte_skip);
  z_stream zs{};
  HAPVOX_CHECK_EQ(inflateInit2(&zs, 15 + 32), Z_OK);  // 15 + 32: auto-detect gzip or zlib
  // Grown as data arrives: a corrupt header must not make us allocate its claimed size.
  std::vector<unsigned char> out;
  std::vector<unsigned char> in_buf(1 << 16);
  std::vector<unsigned char> discard(1 << 16);
  std::uint64_t produced = 0;
  bool ended = false;
  std::string error;
  while (!ended) {
    if (zs.avail_in == 0) {
      in.read(reinterpret_cast<char*>(in_buf.data()), static_cast<std::streamsize>(in_buf.size()));
      const auto got = in.gcount();
      if (got <= 0) break;
      zs.next_in = in_buf.data();
      zs.avail_in = static_cast<uInt>(got);
    }
    // Decompress into the payload when inside it, else into a scratch buffer.
    std::uint64_t room;
    if (produced >= skip && produced < skip + n) {
      const std::uint64_t filled = produced - skip;
      if (filled == out.size()) {
        out.resize(std::min<std::uint64_t>(n, std::max<std::uint64_t>(2 * out.size(), 1 << 20)));
      }
      zs.next_out = out.data() + filled;
      room = std::min<std::uint64_t>(out.size() - filled, std::uint64_t{1} << 30);
    } else {
      zs.next_out = discard.data();
      room = produced < skip ? std::min<std::uint64_t>(skip - produced, discard.size())
                             : discard.size();
    }
    zs.avail_out = static_cast<uInt>(room);
    const uInt before = zs.avail_out;
    const int rc = inflate(&zs, Z_NO_FLUSH);
    produced += before - zs.avail_out;
    if (rc == Z_STREAM_END) {
      ended = true;
    } else if (rc == Z_DATA_ERROR || rc == Z_NEED_DICT || rc == Z_MEM_ERROR ||
               (rc == Z_BUF_ERROR && zs.avail_in > 0)) {
      error = zs.msg != nullptr ? zs.msg : "inflate error " + std::to_string(rc);
      break;
    }
  }
  inflateEnd(&zs);
  if (!error.empty()) throw InputError(path, "corrupt gzip data: " + error);
  const std::uint64_t payload = produced > skip ? produced - skip : 0;
  if (payload < n) throw InputError(path, truncated(n, payload));
  if (payload > n) {
    throw InputError(path, "too much data: expected " + std::to_string(n) + " bytes, got " +
                               std::to_string(payload));
  }
  if (!ended) throw InputError(path, "truncated data: gzip stream ends before its end marker");
  return out;
}

void set_min_max(RawVolume* raw) {
  if (raw->intensity.empty()) return;
  const auto [lo, hi] = std::minmax_element(raw->intensity.begin(), raw->intensity.end());
  raw->min_intensity = *lo;
  raw->max_intensity = *hi;
}

// ---------------------------------------------------------------------------------------
// Grid building.

// Fills a grid from density(i, j, k) over [0, dims), one leaf-sized block at a time so only
// blocks with material allocate leaves. Densities <= 0 stay inactive background.
openvdb::FloatGrid::Ptr build_grid(const Vec3i& dims,
                                   const std::function<float(int, int, int)>& density) {
  using Leaf = openvdb::FloatTree::LeafNodeType;
  constexpr int kDim = static_cast<int>(Leaf::DIM);
  auto grid = openvdb::FloatGrid::create(0.0f);
  auto& tree = grid->tree();
  for (int bz = 0; bz < dims.z(); bz += kDim) {
    for (int by = 0; by < dims.y(); by += kDim) {
      for (int bx = 0; bx < dims.x(); bx += kDim) {
        Leaf* leaf = nullptr;
        const int ez = std::min(bz + kDim, dims.z());
        const int ey = std::min(by + kDim, dims.y());
        const int ex = std::min(bx + kDim, dims.x());
        for (int z = bz; z < ez; ++z) {
          for (int y = by; y < ey; ++y) {
            for (int x = bx; x < ex; ++x) {
              const float d = density(x, y, z);
              if (!(d > 0.0f)) continue;
              if (leaf == nullptr) leaf = tree.touchLeaf(openvdb::Coord(bx, by, bz));
              leaf->setValueOn(Leaf::coordToOffset(openvdb::Coord(x, y, z)), d);
            }
          }
        }
      }
    }
  }
  return grid;
}

// ---------------------------------------------------------------------------------------
// Generators.

struct GeneratorOptions {
  int dims = 128;
  double voxel_mm = 1.0;
  double fill = 0.5;
  double radius_mm = -1.0;  // < 0: default
};

GeneratorOptions parse_generator(const std::string& spec, std::string* name) {
  const std::string source = "generator " + spec;
  const auto colon = spec.find(':');
  *name = spec.substr(0, colon);
  if (*name != "block" && *name != "sphere" && *name != "four-spheres") {
    throw InputError(source,
                     "unknown generator '" + *name + "' (expected block, sphere or four-spheres)");
  }
  std::vector<std::string> allowed = {"dims", "voxel_mm"};
  if (*name == "block") allowed.push_back("fill");
  if (*name == "sphere") allowed.push_back("radius_mm");
  GeneratorOptions opt;
  if (colon == std::string::npos) return opt;
  std::map<std::string, std::string> seen;
  std::size_t start = colon + 1;
  while (true) {
    const auto comma = spec.find(',', start);
    const std::string item = spec.substr(start, comma - start);
    const auto eq = item.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw InputError(source, "expected key=value, got '" + item + "'");
    }
    const std::string key = item.substr(0, eq);
    const std::string value = item.substr(eq + 1);
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      throw InputError(source, "unknown option '" + key + "' (" + *name + " takes " + list + ")");
    }
    if (!seen.emplace(key, value).second) {
      throw InputError(source, "option '" + key + "' given twice");
    }
    if (key == "dims") {
      std::int64_t v = 0;
      if (!parse_int(value, &v) || v < 1 || v > 1024) {
        throw InputError(source, "dims must be an integer in [1, 1024], got '" + value + "'");
      }
      opt.dims = static_cast<int>(v);
    } else {
      double v = 0.0;
      if (!parse_double(value, &v) || !std::isfinite(v)) {
        throw InputError(source, key + " must be a number, got '" + value + "'");
      }
      if (key == "fill") {
        if (v < 0.0 || v > 1.0) throw InputError(source, "fill must lie in [0, 1], got " + value);
        opt.fill = v;
      } else {
        if (v <= 0.0) throw InputError(source, key + " must be positive, got " + value);
        (key == "voxel_mm" ? opt.voxel_mm : opt.radius_mm) = v;
      }
    }
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return opt;
}

bool has_extension(const std::string& path, const std::string& ext) {
  return lower(fs::path(path).extension().string()) == ext;
}

}  // namespace

// -----------------------------------------------------------------------------------------

std::string nrrd_data_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in || fs::is_directory(path)) throw InputError(path, "cannot open file");
  const NrrdHeader header = read_header(in, path);
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
  const NrrdHeader header = read_header(in, path);

  const std::string type_text = lower(require_field(header, "type", path));
  const std::string type_norm = [&] {
    std::string joined;
    for (const auto& tok : split_ws(type_text)) joined += (joined.empty() ? "" : " ") + tok;
    return joined;
  }();
  const auto type_it = sample_type_table().find(type_norm);
  if (type_it == sample_type_table().end()) {
    throw InputError(path, "unsupported sample type '" + type_text + "'");
  }
  const SampleTypeInfo type = type_it->second;

  const std::string& dim_text = require_field(header, "dimension", path);
  std::int64_t dimension = 0;
  if (!parse_int(dim_text, &dimension)) {
    throw InputError(path, "bad dimension '" + dim_text + "'");
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
    throw InputError(path, "sizes must list 3 values, got '" + sizes_text + "'");
  std::int64_t samples = 1;
  for (int i = 0; i < 3; ++i) {
    std::int64_t s = 0;
    if (!parse_int(sizes[static_cast<std::size_t>(i)], &s) || s <= 0) {
      throw InputError(path, "sizes must be positive integers, got '" + sizes_text + "'");
    }
    if (s > kMaxSamples || samples * s > kMaxSamples) {
      throw InputError(path, "sizes '" + sizes_text + "' are too large (over 2^31 samples)");
    }
    samples *= s;
    raw.dims[i] = static_cast<int>(s);
  }

  if (const std::string* kinds = find_field(header, "kinds")) {
    for (const auto& kind : split_ws(lower(*kinds))) {
      if (kind != "domain" && kind != "space" && kind != "none" && kind != "???") {
        throw InputError(path, "axis kind '" + kind +
                                   "' is not supported (only scalar volumes with 3 spatial "
                                   "axes are)");
      }
    }
  }

  // Spacing: space directions (vector norms) win over spacings; default 1 mm.
  if (const std::string* dirs = find_field(header, "space directions")) {
    const auto vecs = split_vectors(*dirs);
    if (vecs.size() != 3) {
      throw InputError(path, "space directions must give 3 vectors, got '" + *dirs + "'");
    }
    for (int i = 0; i < 3; ++i) {
      Vec3d v;
      if (!parse_vector3(vecs[static_cast<std::size_t>(i)], &v)) {
        throw InputError(path, "bad space direction '" + vecs[static_cast<std::size_t>(i)] +
                                   "' (expected (x,y,z))");
      }
      raw.spacing_mm[i] = v.norm();
    }
  } else if (const std::string* spacings = find_field(header, "spacings")) {
    const auto parts = split_ws(*spacings);
    if (parts.size() != 3) {
      throw InputError(path, "spacings must list 3 values, got '" + *spacings + "'");
    }
    for (int i = 0; i < 3; ++i) {
      if (!parse_double(parts[static_cast<std::size_t>(i)], &raw.spacing_mm[i])) {
        throw InputError(path, "bad spacings '" + *spacings + "'");
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
      throw InputError(path, "bad space origin '" + *origin + "' (expected (x,y,z))");
    }
  }

  const std::string encoding = lower(require_field(header, "encoding", path));
  const bool gzip = encoding == "gzip" || encoding == "gz";
  if (!gzip && encoding != "raw") {
    throw InputError(path, "unsupported encoding '" + encoding + "' (expected raw or gzip)");
  }

  bool swap = false;
  if (type.size > 1) {
    const std::string* endian = find_field(header, "endian");
    if (endian == nullptr) throw InputError(path, "missing required field 'endian'");
    const std::string e = lower(*endian);
    if (e != "little" && e != "big") {
      throw InputError(path, "bad endian '" + *endian + "' (expected little or big)");
    }
    swap = (e == "big") != (std::endian::native == std::endian::big);
  }

  std::int64_t line_skip = 0;
  std::int64_t byte_skip = 0;
  if (const std::string* v = find_field(header, "line skip")) {
    if (!parse_int(*v, &line_skip) || line_skip < 0) {
      throw InputError(path, "line skip must be a non-negative integer, got '" + *v + "'");
    }
  }
  if (const std::string* v = find_field(header, "byte skip")) {
    if (!parse_int(*v, &byte_skip) || byte_skip < -1) {
      throw InputError(path, "byte skip must be a non-negative integer (or -1), got '" + *v + "'");
    }
  }

  // Data source: a detached file, else what follows the header's blank line.
  std::ifstream detached;
  std::istream* data = &in;
  if (const std::string* data_file = find_field(header, "data file")) {
    if (data_file->rfind("LIST", 0) == 0 || data_file->find('%') != std::string::npos ||
        split_ws(*data_file).size() != 1) {
      throw InputError(path, "multi-file data ('data file: " + *data_file + "') is not supported");
    }
    fs::path file(*data_file);
    if (file.is_relative()) file = fs::path(path).parent_path() / file;
    detached.open(file, std::ios::binary);
    if (!detached || fs::is_directory(file)) {
      throw InputError(path, "cannot open data file '" + file.string() + "'");
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
  switch (type.type) {
    case SampleType::kInt8:
      convert_samples<std::int8_t>(bytes, swap, &raw.intensity, path);
      break;
    case SampleType::kUint8:
      convert_samples<std::uint8_t>(bytes, swap, &raw.intensity, path);
      break;
    case SampleType::kInt16:
      convert_samples<std::int16_t>(bytes, swap, &raw.intensity, path);
      break;
    case SampleType::kUint16:
      convert_samples<std::uint16_t>(bytes, swap, &raw.intensity, path);
      break;
    case SampleType::kInt32:
      convert_samples<std::int32_t>(bytes, swap, &raw.intensity, path);
      break;
    case SampleType::kUint32:
      convert_samples<std::uint32_t>(bytes, swap, &raw.intensity, path);
      break;
    case SampleType::kInt64:
      convert_samples<std::int64_t>(bytes, swap, &raw.intensity, path);
      break;
    case SampleType::kUint64:
      convert_samples<std::uint64_t>(bytes, swap, &raw.intensity, path);
      break;
    case SampleType::kFloat:
      convert_samples<float>(bytes, swap, &raw.intensity, path);
      break;
    case SampleType::kDouble:
      convert_samples<double>(bytes, swap, &raw.intensity, path);
      break;
  }
  set_min_max(&raw);
  return raw;
}

void write_nrrd(const DensityField& field, const std::string& path) {
  const Vec3i& dims = field.dims();
  const auto n = static_cast<std::size_t>(dims.x()) * static_cast<std::size_t>(dims.y()) *
                 static_cast<std::size_t>(dims.z());
  std::vector<float> values(n);
  {
    auto acc = field.grid().getConstAccessor();
    std::size_t i = 0;
    for (int z = 0; z < dims.z(); ++z) {
      for (int y = 0; y < dims.y(); ++y) {
        for (int x = 0; x < dims.x(); ++x) values[i++] = acc.getValue(openvdb::Coord(x, y, z));
      }
    }
  }

  // gzip wrapper (15 + 16) so other tools that insist on gzip, not zlib, can read it.
  z_stream zs{};
  HAPVOX_CHECK_EQ(deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY), Z_OK);
  const std::size_t in_bytes = n * sizeof(float);
  std::vector<unsigned char> compressed(deflateBound(&zs, static_cast<uLong>(in_bytes)));
  zs.next_in = reinterpret_cast<Bytef*>(values.data());
  zs.next_out = compressed.data();
  // Feed in chunks: avail_in/avail_out are 32-bit.
  std::size_t fed = 0;
  int rc = Z_OK;
  while (rc != Z_STREAM_END) {
    if (zs.avail_in == 0 && fed < in_bytes) {
      const std::size_t chunk = std::min<std::size_t>(in_bytes - fed, 1u << 30);
      zs.avail_in = static_cast<uInt>(chunk);
      fed += chunk;
    }
    zs.avail_out = static_cast<uInt>(std::min<std::size_t>(
        compressed.size() - static_cast<std::size_t>(zs.next_out - compressed.data()), 1u << 30));
    rc = deflate(&zs, fed == in_bytes ? Z_FINISH : Z_NO_FLUSH);
    HAPVOX_CHECK(rc == Z_OK || rc == Z_STREAM_END || rc == Z_BUF_ERROR);
  }
  const std::size_t out_bytes = static_cast<std::size_t>(zs.next_out - compressed.data());
  deflateEnd(&zs);

  // Space directions rather than spacings: NRRD forbids "space origin" without a space,
  // and teem/Slicer/ITK reject spacings alongside one.
  std::ostringstream header;
  header.precision(17);
  const Vec3d& s = field.voxel_size_mm();
  const Vec3d& o = field.origin_mm();
  header << "NRRD0004\n"
         << "# written by hapvox: density in [0, 1]\n"
         << "type: float\n"
         << "dimension: 3\n"
         << "space dimension: 3\n"
         << "sizes: " << dims.x() << " " << dims.y() << " " << dims.z() << "\n"
         << "space directions: (" << s.x() << ",0,0) (0," << s.y() << ",0) (0,0," << s.z() << ")\n"
         << "kinds: domain domain domain\n"
         << "endian: " << (std::endian::native == std::endian::big ? "big" : "little") << "\n"
         << "encoding: gzip\n"
         << "space origin: (" << o.x() << "," << o.y() << "," << o.z() << ")\n\n";

  const std::string partial = path + ".partial";
  {
    std::ofstream out(partial, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(path, "cannot write file");
    const std::string h = header.str();
    out.write(h.data(), static_cast<std::streamsize>(h.size()));
    out.write(reinterpret_cast<const char*>(compressed.data()),
              static_cast<std::streamsize>(out_bytes));
    out.close();
    if (!out) throw InputError(path, "error while writing file");
  }
  std::error_code ec;
  fs::rename(partial, path, ec);
  if (ec) throw InputError(path, "cannot rename " + partial + ": " + ec.message());
}

double otsu_threshold(const RawVolume& raw) {
  constexpr int kBins = 256;
  const double lo = raw.min_intensity;
  const double hi = raw.max_intensity;
  if (raw.intensity.empty() || !(hi > lo)) return lo;  // constant volume: no split exists
  const double width = (hi - lo) / kBins;
  std::array<double, kBins> hist{};
  for (float v : raw.intensity) {
    const int bin = std::clamp(static_cast<int>((v - lo) / width), 0, kBins - 1);
    hist[static_cast<std::size_t>(bin)] += 1.0;
  }
  const double total = static_cast<double>(raw.intensity.size());
  double sum_all = 0.0;
  for (int i = 0; i < kBins; ++i) sum_all += i * hist[static_cast<std::size_t>(i)];
  double w0 = 0.0;
  double sum0 = 0.0;
  double best = -1.0;
  int best_bin = 0;
  for (int k = 0; k < kBins - 1; ++k) {
    w0 += hist[static_cast<std::size_t>(k)];
    sum0 += k * hist[static_cast<std::size_t>(k)];
    const double w1 = total - w0;
    if (w0 == 0.0 || w1 == 0.0) continue;
    const double mean0 = sum0 / w0;
    const double mean1 = (sum_all - sum0) / w1;
    const double between = w0 * w1 * (mean0 - mean1) * (mean0 - mean1);
    if (between > best) {
      best = between;
      best_bin = k;
    }
  }
  // Threshold at the upper edge of the last background bin: v >= t is material.
  return lo + (best_bin + 1) * width;
}

DensityField map_to_density(const RawVolume& raw, const IntensityMapping& mapping,
                            const std::string& source_name) {
  const Vec3i dims = raw.dims;
  HAPVOX_CHECK_EQ(raw.intensity.size(), static_cast<std::size_t>(dims.x()) *
                                            static_cast<std::size_t>(dims.y()) *
                                            static_cast<std::size_t>(dims.z()));
  if (!std::isfinite(mapping.low) ||
      (mapping.kind == IntensityMapping::Kind::kWindow && !std::isfinite(mapping.high))) {
    throw InputError(source_name, "intensity mapping bounds must be finite");
  }
  const std::size_t nx = static_cast<std::size_t>(dims.x());
  const std::size_t nxy = nx * static_cast<std::size_t>(dims.y());
  auto at = [&](int x, int y, int z) {
    return raw.intensity[static_cast<std::size_t>(z) * nxy + static_cast<std::size_t>(y) * nx +
                         static_cast<std::size_t>(x)];
  };
  openvdb::FloatGrid::Ptr grid;
  if (mapping.kind == IntensityMapping::Kind::kWindow) {
    if (!(mapping.high > mapping.low)) {
      throw InputError(source_name, "window high must exceed low");
    }
    const double low = mapping.low;
    const double inv = 1.0 / (mapping.high - mapping.low);
    grid = build_grid(dims, [&](int x, int y, int z) {
      return static_cast<float>(std::clamp((at(x, y, z) - low) * inv, 0.0, 1.0));
    });
  } else {
    const double t =
        mapping.kind == IntensityMapping::Kind::kAuto ? otsu_threshold(raw) : mapping.low;
    grid = build_grid(dims, [&](int x, int y, int z) { return at(x, y, z) >= t ? 1.0f : 0.0f; });
  }
  return DensityField(grid, raw.spacing_mm, raw.origin_mm, dims);
}

namespace {

// Densities a .vdb may hold: sculpted volumes exceed 1 where clay is compressed; far
// beyond that is a corrupt or foreign grid (and would overflow the mass grid's units).
constexpr float kMaxDensity = 1000.0f;

// OpenVDB trusts its input: bytes flipped inside a grid's data can make it allocate
// without bound, loop, or corrupt the heap rather than throw. So a .vdb is first read by a
// child process, with its memory capped (outside sanitizer builds, whose shadow memory a
// cap would break), a time limit and stderr silenced; only if that read succeeds is the
// file read here. Throws InputError saying how the child's read failed.
void check_vdb_in_child(const std::string& path) {
#if defined(__SANITIZE_THREAD__)
  // ThreadSanitizer kills the child of a multithreaded fork: there, read directly.
  std::ifstream proc_status("/proc/self/status");
  for (std::string line; std::getline(proc_status, line);) {
    if (line.rfind("Threads:", 0) == 0 && std::stoi(line.substr(8)) > 1) return;
  }
#endif
  int fds[2];
  if (pipe(fds) != 0) return;  // no child: the read below is on its own
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    return;
  }
  if (pid == 0) {
    close(fds[0]);
    const int null_fd = open("/dev/null", O_WRONLY);
    if (null_fd >= 0) dup2(null_fd, STDERR_FILENO);
#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
    if (pages > 0 && page > 0) {
      const rlim_t half = static_cast<rlim_t>(pages) / 2 * static_cast<rlim_t>(page);
      const rlimit cap{half, half};
      setrlimit(RLIMIT_AS, &cap);
    }
#endif
    std::error_code ec;
    const auto bytes = fs::file_size(path, ec);
    alarm(30 + static_cast<unsigned>(ec ? 0 : bytes >> 20));  // 30 s plus 1 s per MB
    std::string message;
    int code = 0;
    openvdb::io::File file(path);
    try {
      file.open(false);
    } catch (const std::exception& e) {
      message = std::string("not a VDB file (") + e.what() + ")";
      code = 2;
    }
    if (code == 0) {
      try {
        file.getGrids();
        file.close();
      } catch (const std::bad_alloc&) {
        message = "corrupt or truncated VDB file (its sizes ask for more memory than exists)";
        code = 2;
      } catch (const std::exception& e) {
        message = std::string("cannot read VDB grid: ") + e.what();
        code = 2;
      }
    }
    if (write(fds[1], message.data(), message.size()) < 0) code = 3;
    _exit(code);
  }
  close(fds[1]);
  std::string message;
  char buffer[512];
  for (ssize_t n; (n = read(fds[0], buffer, sizeof buffer)) != 0;) {
    if (n > 0) {
      message.append(buffer, static_cast<std::size_t>(n));
    } else if (errno != EINTR) {
      break;
    }
  }
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
  if (WIFEXITED(status) && WEXITSTATUS(status) == 2) throw InputError(path, message);
  if (WIFSIGNALED(status) && WTERMSIG(status) == SIGALRM) {
    throw InputError(path, "corrupt or truncated VDB file (reading it did not finish)");
  }
  throw InputError(path, "corrupt or truncated VDB file (reading it crashed OpenVDB)");
}

}  // namespace

DensityField read_vdb(const std::string& path) {
  initialize_openvdb();
  if (!fs::is_regular_file(path)) throw InputError(path, "cannot open file");
  check_vdb_in_child(path);
  openvdb::io::File file(path);
  openvdb::FloatGrid::Ptr grid;
  try {
    file.open(false);  // no delayed loading: the file may be replaced while we run
  } catch (const openvdb::Exception& e) {
    throw InputError(path, std::string("not a VDB file (") + e.what() + ")");
  }
  try {
    // Prefer a float grid named "density", else the first float grid.
    std::optional<std::string> name;
    const openvdb::GridPtrVecPtr metas = file.readAllGridMetadata();
    for (const auto& meta : *metas) {
      if (!meta->isType<openvdb::FloatGrid>()) continue;
      if (!name || meta->getName() == "density") name = meta->getName();
      if (*name == "density") break;
    }
    if (name) grid = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid(*name));
    file.close();
  } catch (const openvdb::Exception& e) {
    throw InputError(path, std::string("cannot read VDB grid: ") + e.what());
  } catch (const std::exception& e) {
    throw InputError(path, std::string("corrupt or truncated VDB file (") + e.what() + ")");
  }
  if (grid == nullptr) {
    throw InputError(path, "no float grid (expected a grid named \"density\")");
  }
  if (grid->getGridClass() == openvdb::GRID_LEVEL_SET) {
    throw InputError(
        path, "grid \"" + grid->getName() + "\" is a level set, not a density (fog volume) grid");
  }
  if (grid->background() != 0.0f) {
    throw InputError(path, "grid \"" + grid->getName() + "\" has background " +
                               std::to_string(grid->background()) + ", expected 0");
  }
  for (auto it = grid->cbeginValueOn(); it; ++it) {
    if (!std::isfinite(*it)) throw InputError(path, "grid contains NaN or infinite values");
    if (*it < 0.0f || *it > kMaxDensity) {
      throw InputError(path, "grid contains density " + std::to_string(*it) + " outside [0, " +
                                 std::to_string(static_cast<int>(kMaxDensity)) +
                                 "] (1 is the normal density)");
    }
  }
  const openvdb::math::Transform& xform = grid->transform();
  if (!xform.isLinear()) throw InputError(path, "grid transform is not linear");
  const openvdb::Vec3d vs = xform.voxelSize();
  const openvdb::Vec3d origin = xform.indexToWorld(openvdb::Vec3d(0.0));
  const Vec3d voxel_size(vs.x(), vs.y(), vs.z());
  if (!voxel_size.allFinite() || voxel_size.minCoeff() <= 0.0) {
    throw InputError(path, "grid voxel size must be positive");
  }

  Vec3i dims;
  if (auto meta = grid->getMetadata<openvdb::Vec3IMetadata>("hapvox_dims")) {
    const openvdb::Vec3i d = meta->value();
    dims = Vec3i(d.x(), d.y(), d.z());
    if (dims.minCoeff() <= 0) throw InputError(path, "hapvox_dims metadata must be positive");
  } else {
    const openvdb::CoordBBox box = grid->evalActiveVoxelBoundingBox();
    if (box.empty()) throw InputError(path, "grid \"" + grid->getName() + "\" is empty");
    dims = Vec3i(std::max(1, box.max().x() + 1), std::max(1, box.max().y() + 1),
                 std::max(1, box.max().z() + 1));
  }
  return DensityField(grid, voxel_size, Vec3d(origin.x(), origin.y(), origin.z()), dims);
}

void write_vdb(const DensityField& field, const std::string& path) {
  initialize_openvdb();
  // A new grid sharing the field's tree, so naming and metadata do not touch the field.
  auto grid = openvdb::FloatGrid::create(field.grid_ptr()->treePtr());
  grid->setName("density");
  grid->setGridClass(openvdb::GRID_FOG_VOLUME);
  const Vec3d& s = field.voxel_size_mm();
  const Vec3d& o = field.origin_mm();
  grid->setTransform(
      std::make_shared<openvdb::math::Transform>(std::make_shared<openvdb::math::ScaleTranslateMap>(
          openvdb::Vec3d(s.x(), s.y(), s.z()), openvdb::Vec3d(o.x(), o.y(), o.z()))));
  const Vec3i& d = field.dims();
  grid->insertMeta("hapvox_dims", openvdb::Vec3IMetadata(openvdb::Vec3i(d.x(), d.y(), d.z())));

  const std::string partial = path + ".partial";
  try {
    openvdb::io::File file(partial);
    file.write(openvdb::GridCPtrVec{grid});
    file.close();
  } catch (const openvdb::Exception& e) {
    throw InputError(path, std::string("cannot write file: ") + e.what());
  }
  std::error_code ec;
  fs::rename(partial, path, ec);
  if (ec) throw InputError(path, "cannot rename " + partial + ": " + ec.message());
}

DensityField generate_volume(const std::string& spec) {
  std::string name;
  const GeneratorOptions opt = parse_generator(spec, &name);
  const int n = opt.dims;
  const Vec3i dims = Vec3i::Constant(n);
  const Vec3d voxel = Vec3d::Constant(opt.voxel_mm);
  const Vec3d origin = Vec3d::Zero();
  // Box centre in index space: voxel faces span [-0.5, n - 0.5].
  const double c = 0.5 * (n - 1);

  if (name == "block") {
    auto grid = openvdb::FloatGrid::create(0.0f);
    // k < fill * n, with a little slack so fill=0.3, n=10 gives 3 layers, not 4.
    const int layers = std::min(n, static_cast<int>(std::ceil(opt.fill * n - 1e-9)));
    if (layers > 0) {
      grid->tree().fill(
          openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(n - 1, n - 1, layers - 1)), 1.0f,
          true);
      // The force code walks leaves; dense tiles would hide the voxels from it.
      grid->tree().voxelizeActiveTiles();
    }
    return DensityField(grid, voxel, origin, dims);
  }

  if (name == "sphere") {
    const double r_mm = opt.radius_mm > 0.0 ? opt.radius_mm : 0.35 * n * opt.voxel_mm;
    const double r = r_mm / opt.voxel_mm;
    const double r2 = r * r;
    auto grid = build_grid(dims, [&](int x, int y, int z) {
      const double dx = x - c, dy = y - c, dz = z - c;
      return dx * dx + dy * dy + dz * dz <= r2 ? 1.0f : 0.0f;
    });
    return DensityField(grid, voxel, origin, dims);
  }

  // four-spheres: centres on a regular tetrahedron around the box centre. With radius 0.18 n
  // and centre distance 0.3 n, neighbours are 0.49 n apart (> 2r = 0.36 n) and every sphere
  // stays 0.15 n inside the box faces.
  const double r = 0.18 * n;
  const double d = 0.3 * n / std::sqrt(3.0);  // per-axis offset of each centre
  const std::array<Vec3d, 4> centres = {Vec3d(c + d, c + d, c + d), Vec3d(c + d, c - d, c - d),
                                        Vec3d(c - d, c + d, c - d), Vec3d(c - d, c - d, c + d)};
  const std::array<float, 4> densities = {0.4f, 0.6f, 0.8f, 1.0f};
  auto grid = build_grid(dims, [&](int x, int y, int z) {
    const Vec3d p(x, y, z);
    for (std::size_t i = 0; i < centres.size(); ++i) {
      if ((p - centres[i]).squaredNorm() <= r * r) return densities[i];
    }
    return 0.0f;
  });
  return DensityField(grid, voxel, origin, dims);
}

bool is_generator_spec(const std::string& spec) {
  const std::string name = spec.substr(0, spec.find(':'));
  if (name != "block" && name != "sphere" && name != "four-spheres") return false;
  std::error_code ec;
  return !fs::exists(spec, ec);
}

DensityField load_volume(const std::string& spec, const IntensityMapping& mapping) {
  if (is_generator_spec(spec)) return generate_volume(spec);
  if (has_extension(spec, ".nrrd") || has_extension(spec, ".nhdr")) {
    return map_to_density(read_nrrd(spec), mapping, spec);
  }
  if (has_extension(spec, ".vdb")) return read_vdb(spec);
  throw InputError(spec,
                   "unknown volume format (expected .nrrd, .nhdr or .vdb, or a generator: "
                   "block, sphere, four-spheres)");
}

}  // namespace hapvox::engine
