#include "engine/io/payload.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "engine/check.h"
#include "engine/errors.h"
#include "engine/input_limits.h"

namespace hapvox::engine::io {
namespace {

std::string truncated(std::uint64_t expected, std::uint64_t got) {
  return "truncated data: expected " + std::to_string(expected) + " bytes, got " +
         std::to_string(got);
}

}  // namespace

void check_volume_budget(const std::int64_t (&dims)[3], std::size_t sample_bytes,
                         const std::string& type_name, const std::string& path) {
  // In doubles: a corrupt header's dims may overflow any integer product.
  const double decoded_bytes = static_cast<double>(dims[0]) * static_cast<double>(dims[1]) *
                               static_cast<double>(dims[2]) *
                               static_cast<double>(std::max<std::size_t>(sample_bytes, 4));
  const InputLimits& limits = input_limits();
  if (decoded_bytes <= static_cast<double>(limits.max_input_bytes())) return;
  const auto mb = static_cast<std::uint64_t>(std::ceil(decoded_bytes / (1 << 20)));
  const std::string type = type_name.empty() ? "" : " " + type_name;
  throw InputError(path, std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " +
                             std::to_string(dims[2]) + type + " samples take " +
                             std::to_string(mb) + " MB decoded, " +
                             over_limit(limits.max_input_mb, "MB", "--max-input-mb"));
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

std::vector<float> dense_floats(const DensityField& field) {
  const Vec3i& dims = field.dims();
  std::vector<float> values(static_cast<std::size_t>(dims.x()) *
                            static_cast<std::size_t>(dims.y()) *
                            static_cast<std::size_t>(dims.z()));
  auto acc = field.grid().getConstAccessor();
  std::size_t i = 0;
  for (int z = 0; z < dims.z(); ++z) {
    for (int y = 0; y < dims.y(); ++y) {
      for (int x = 0; x < dims.x(); ++x) values[i++] = acc.getValue(openvdb::Coord(x, y, z));
    }
  }
  return values;
}

std::vector<unsigned char> deflate_bytes(const void* data, std::size_t size, bool gzip) {
  z_stream zs{};
  HAPVOX_CHECK_EQ(deflateInit2(&zs, 6, Z_DEFLATED, gzip ? 15 + 16 : 15, 8, Z_DEFAULT_STRATEGY),
                  Z_OK);
  const std::size_t in_bytes = size;
  std::vector<unsigned char> compressed(deflateBound(&zs, static_cast<uLong>(in_bytes)));
  zs.next_in = static_cast<Bytef*>(const_cast<void*>(data));
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
  compressed.resize(static_cast<std::size_t>(zs.next_out - compressed.data()));
  deflateEnd(&zs);
  return compressed;
}

}  // namespace hapvox::engine::io
