#include "haptics/bridge_packet.h"

#include <bit>
#include <cmath>
#include <cstring>

namespace hapvox::haptics {
namespace {

// Little-endian fields, written and read byte by byte: the same bytes on any host.
class Writer {
 public:
  explicit Writer(std::uint8_t* out) : out_(out) {}
  void u16(std::uint16_t v) { put(v, 2); }
  void u32(std::uint32_t v) { put(v, 4); }
  void u64(std::uint64_t v) { put(v, 8); }
  void f64(double v) { u64(std::bit_cast<std::uint64_t>(v)); }
  std::size_t size() const { return size_; }
  void bytes(const std::uint8_t* b, std::size_t n) {
    std::memcpy(out_ + size_, b, n);
    size_ += n;
  }

 private:
  void put(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) out_[size_++] = static_cast<std::uint8_t>(v >> (8 * i));
  }
  std::uint8_t* out_;
  std::size_t size_ = 0;
};

class Reader {
 public:
  explicit Reader(const std::uint8_t* data) : data_(data) {}
  std::uint16_t u16() { return static_cast<std::uint16_t>(get(2)); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(get(4)); }
  std::uint64_t u64() { return get(8); }
  double f64() { return std::bit_cast<double>(get(8)); }

 private:
  std::uint64_t get(int n) {
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(data_[at_++]) << (8 * i);
    return v;
  }
  const std::uint8_t* data_;
  std::size_t at_ = 0;
};

void write_header(Writer& w, const PacketHeader& h, PacketKind kind) {
  w.bytes(kBridgeMagic.data(), kBridgeMagic.size());
  w.u16(h.version);
  w.u16(static_cast<std::uint16_t>(kind));
  w.u32(h.sequence);
  w.u64(h.sent_ns);
}

// The header's checks, in the order a receiver can make them: length first (nothing is
// read past `size`), then what the bytes say; with a key, the tag before the body is read.
PacketError read_header(const std::uint8_t* data, std::size_t size, PacketKind kind,
                        std::size_t packet_bytes, const BridgeKey* key, PacketHeader* header,
                        Reader& r) {
  if (size < kBridgeHeaderBytes) return PacketError::too_short;
  if (std::memcmp(data, kBridgeMagic.data(), kBridgeMagic.size()) != 0) {
    return PacketError::bad_magic;
  }
  Reader h(data + kBridgeMagic.size());
  header->version = h.u16();
  const std::uint16_t got_kind = h.u16();
  header->sequence = h.u32();
  header->sent_ns = h.u64();
  if (header->version != kBridgeVersion) return PacketError::bad_version;
  if (got_kind != static_cast<std::uint16_t>(kind)) return PacketError::wrong_kind;
  header->kind = kind;
  if (key != nullptr && size == packet_bytes) return PacketError::bad_tag;  // none
  const std::size_t tagged_bytes = packet_bytes + (key != nullptr ? kBridgeTagBytes : 0);
  if (size < tagged_bytes) return PacketError::too_short;
  if (size > tagged_bytes) return PacketError::oversized;
  if (key != nullptr && !key->verify(data, packet_bytes, data + packet_bytes)) {
    return PacketError::bad_tag;
  }
  r = Reader(data + kBridgeHeaderBytes);
  return PacketError::none;
}

}  // namespace

const char* packet_error_name(PacketError error) {
  switch (error) {
    case PacketError::none:
      return "none";
    case PacketError::too_short:
      return "too short";
    case PacketError::oversized:
      return "oversized";
    case PacketError::bad_magic:
      return "not a bridge packet";
    case PacketError::bad_version:
      return "wrong version";
    case PacketError::wrong_kind:
      return "wrong kind";
    case PacketError::not_finite:
      return "not finite";
    case PacketError::bad_orientation:
      return "orientation not a unit quaternion";
    case PacketError::bad_tag:
      return "wrong or missing tag";
  }
  return "unknown";
}

namespace {

// Appends the tag of the `size` bytes at `out` when there is a key. Returns the new size.
std::size_t append_tag(std::uint8_t* out, std::size_t size, const BridgeKey* key) {
  if (key == nullptr) return size;
  key->sign(out, size, out + size);
  return size + kBridgeTagBytes;
}

}  // namespace

std::size_t encode_position(const PositionPacket& p, std::uint8_t* out, const BridgeKey* key) {
  Writer w(out);
  write_header(w, p.header, PacketKind::position);
  for (int a = 0; a < 3; ++a) w.f64(p.position_mm[a]);
  for (double q : p.orientation_wxyz) w.f64(q);
  w.u32(p.buttons);
  w.u32(p.flags);
  w.u32(p.round_trip_ns);
  return append_tag(out, w.size(), key);
}

std::size_t encode_force(const ForcePacket& p, std::uint8_t* out, const BridgeKey* key) {
  Writer w(out);
  write_header(w, p.header, PacketKind::force);
  w.u32(p.echo_sequence);
  w.u64(p.echo_sent_ns);
  w.u64(p.tick);
  for (int a = 0; a < 3; ++a) w.f64(p.force_n[a]);
  w.u32(p.status);
  return append_tag(out, w.size(), key);
}

PacketError parse_position(const std::uint8_t* data, std::size_t size, PositionPacket* out,
                           const BridgeKey* key) {
  PositionPacket p;
  Reader r(data);
  if (const PacketError e =
          read_header(data, size, PacketKind::position, kPositionPacketBytes, key, &p.header, r);
      e != PacketError::none) {
    return e;
  }
  for (int a = 0; a < 3; ++a) p.position_mm[a] = r.f64();
  for (double& q : p.orientation_wxyz) q = r.f64();
  p.buttons = r.u32();
  p.flags = r.u32();
  p.round_trip_ns = r.u32();
  if (!p.position_mm.allFinite()) return PacketError::not_finite;
  if ((p.flags & kPositionHasOrientation) != 0) {
    double norm2 = 0.0;
    for (double q : p.orientation_wxyz) {
      if (!std::isfinite(q)) return PacketError::not_finite;
      norm2 += q * q;
    }
    if (!(std::abs(std::sqrt(norm2) - 1.0) <= 1e-6)) return PacketError::bad_orientation;
  }
  *out = p;
  return PacketError::none;
}

PacketError parse_force(const std::uint8_t* data, std::size_t size, ForcePacket* out,
                        const BridgeKey* key) {
  ForcePacket p;
  Reader r(data);
  if (const PacketError e =
          read_header(data, size, PacketKind::force, kForcePacketBytes, key, &p.header, r);
      e != PacketError::none) {
    return e;
  }
  p.echo_sequence = r.u32();
  p.echo_sent_ns = r.u64();
  p.tick = r.u64();
  for (int a = 0; a < 3; ++a) p.force_n[a] = r.f64();
  p.status = r.u32();
  if (!p.force_n.allFinite()) return PacketError::not_finite;
  *out = p;
  return PacketError::none;
}

}  // namespace hapvox::haptics
