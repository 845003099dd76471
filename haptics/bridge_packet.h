#pragma once
// The device bridge's wire format (docs/formats.md, "Device bridge packets"): UDP datagrams,
// little-endian whatever the host, versioned, each with the sender's sequence number and
// timestamp. A device program (OpenHaptics, Force Dimension, CHAI3D, a ROS node, or
// `hapvox device-sim`) sends a position packet per servo tick; hapvox answers each with a
// force packet that echoes its sequence number and timestamp, so the sender measures the
// round trip on its own clock.
//
// Parsing never throws, allocates or reads past `size`: a packet is accepted or counted
// under one PacketError and ignored (the force thread parses them).
//
//   header (20 bytes)   magic "HVXB", u16 version (1), u16 kind, u32 sequence,
//                       u64 sent_ns (the sender's monotonic clock)
//   position (kind 1)   header, f64[3] position_mm (device frame), f64[4] orientation
//                       (w, x, y, z; valid when flags bit 0), u32 buttons (bit 0: grab,
//                       bit 1: dead-man, released = force off), u32 flags, u32
//                       round_trip_ns (the sender's last measured round trip)   88 bytes
//   force (kind 2)      header, u32 echo_sequence, u64 echo_sent_ns, u64 tick,
//                       f64[3] force_n, u32 status (ForceStatus bits)          68 bytes
//   tag (keyed only)    HMAC-SHA256 of all the bytes before it (haptics/bridge_key.h),
//                       32 bytes: a keyed position packet is 120 bytes, a force packet 100

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>

#include "haptics/bridge_key.h"

namespace hapvox::haptics {

using Vec3d = Eigen::Vector3d;

inline constexpr std::array<std::uint8_t, 4> kBridgeMagic = {'H', 'V', 'X', 'B'};
inline constexpr std::uint16_t kBridgeVersion = 1;
inline constexpr std::size_t kBridgeHeaderBytes = 20;
inline constexpr std::size_t kPositionPacketBytes = 88;
inline constexpr std::size_t kForcePacketBytes = 68;
/// A receive buffer this large holds any packet of any version; a datagram longer than a
/// packet of its kind is refused as oversized.
inline constexpr std::size_t kBridgeMaxDatagramBytes = 512;

enum class PacketKind : std::uint16_t { position = 1, force = 2 };

/// Button bits of a position packet.
inline constexpr std::uint32_t kButtonGrab = 1u << 0;
inline constexpr std::uint32_t kButtonDeadMan = 1u << 1;
/// Flag bits of a position packet.
inline constexpr std::uint32_t kPositionHasOrientation = 1u << 0;
inline constexpr std::uint32_t kPositionEndOfSession = 1u << 1;  // the sender's last packet
/// Status bits of a force packet.
inline constexpr std::uint32_t kForceRamping = 1u << 0;   // ramp factor below 1
inline constexpr std::uint32_t kForceClamped = 1u << 1;   // clamped to the device limit
inline constexpr std::uint32_t kForceFault = 1u << 2;     // model fault: sent as zero
inline constexpr std::uint32_t kForceSilence = 1u << 3;   // no fresh position: ramping down
inline constexpr std::uint32_t kForceReleased = 1u << 4;  // dead-man released: zero

struct PacketHeader {
  std::uint16_t version = kBridgeVersion;
  PacketKind kind = PacketKind::position;
  std::uint32_t sequence = 0;
  std::uint64_t sent_ns = 0;
};

struct PositionPacket {
  PacketHeader header;
  Vec3d position_mm = Vec3d::Zero();
  std::array<double, 4> orientation_wxyz = {1.0, 0.0, 0.0, 0.0};
  std::uint32_t buttons = 0;
  std::uint32_t flags = 0;
  /// The round trip the sender measured for the newest force packet it got (its clock at
  /// arrival minus the echoed sent_ns), saturated at 2^32 - 1; 0 before the first. hapvox
  /// records them, so the session holds the latency its device saw.
  std::uint32_t round_trip_ns = 0;
};

struct ForcePacket {
  PacketHeader header;  // kind force; its own sequence and send time
  std::uint32_t echo_sequence = 0;
  std::uint64_t echo_sent_ns = 0;
  std::uint64_t tick = 0;
  Vec3d force_n = Vec3d::Zero();
  std::uint32_t status = 0;
};

/// Why a datagram was ignored; each is counted separately in the session.
enum class PacketError {
  none = 0,
  too_short,        // shorter than its kind's packet (or than a header)
  oversized,        // longer than its kind's packet
  bad_magic,        // not a bridge packet
  bad_version,      // a version this build does not speak
  wrong_kind,       // a kind the receiver does not take (a force packet sent to hapvox)
  not_finite,       // a NaN or infinite position or orientation
  bad_orientation,  // an orientation flagged valid whose norm is not 1 (to 1e-6)
  bad_tag,          // keyed: the tag is missing (an unkeyed packet's length) or wrong
};
inline constexpr int kPacketErrorCount = 9;

/// "too short", "oversized", ... (for counts in sessions and messages).
const char* packet_error_name(PacketError error);

/// The length of a position (force) packet, with `key` (not null) its tag's too.
inline std::size_t position_packet_bytes(const BridgeKey* key) {
  return kPositionPacketBytes + (key != nullptr ? kBridgeTagBytes : 0);
}
inline std::size_t force_packet_bytes(const BridgeKey* key) {
  return kForcePacketBytes + (key != nullptr ? kBridgeTagBytes : 0);
}

/// Writes the packet's 88 (68) bytes to `out` (at least position_packet_bytes(key) large),
/// followed by their tag when `key` is not null. Returns the size.
std::size_t encode_position(const PositionPacket& packet, std::uint8_t* out,
                            const BridgeKey* key = nullptr);
std::size_t encode_force(const ForcePacket& packet, std::uint8_t* out,
                         const BridgeKey* key = nullptr);

/// Parses `size` bytes as a position (force) packet into `out`. On any error `out` is left
/// as it was. `size` may be the datagram's real length beyond the buffer (MSG_TRUNC):
/// only the first min(size, kind's length) bytes are read. With `key` the packet must end in
/// its tag (bad_tag when it is wrong, or when the datagram has an unkeyed packet's length);
/// nothing after the header is believed before the tag is checked.
PacketError parse_position(const std::uint8_t* data, std::size_t size, PositionPacket* out,
                           const BridgeKey* key = nullptr);
PacketError parse_force(const std::uint8_t* data, std::size_t size, ForcePacket* out,
                        const BridgeKey* key = nullptr);

}  // namespace hapvox::haptics
