// The device bridge's wire format: the documented bytes (little-endian, at their offsets),
// round trips, and every way a datagram is refused.

#include "haptics/bridge_packet.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

namespace hapvox::haptics {
namespace {

PositionPacket sample_position() {
  PositionPacket p;
  p.header.sequence = 0x01020304u;
  p.header.sent_ns = 0x1122334455667788ull;
  p.position_mm = Vec3d(1.0, -2.5, 1e-300);
  p.orientation_wxyz = {std::sqrt(0.5), 0.0, -std::sqrt(0.5), 0.0};
  p.buttons = kButtonGrab | kButtonDeadMan;
  p.flags = kPositionHasOrientation;
  p.round_trip_ns = 0xA1B2C3D4u;
  return p;
}

std::vector<std::uint8_t> encoded(const PositionPacket& p) {
  std::vector<std::uint8_t> bytes(kBridgeMaxDatagramBytes);
  bytes.resize(encode_position(p, bytes.data()));
  return bytes;
}

TEST(BridgePacket, PositionBytesAreTheDocumentedLittleEndianLayout) {
  const std::vector<std::uint8_t> b = encoded(sample_position());
  ASSERT_EQ(b.size(), kPositionPacketBytes);
  ASSERT_EQ(b.size(), 88u);
  EXPECT_EQ(std::vector<std::uint8_t>(b.begin(), b.begin() + 4),
            (std::vector<std::uint8_t>{'H', 'V', 'X', 'B'}));
  EXPECT_EQ(b[4], 1);  // version 1
  EXPECT_EQ(b[5], 0);
  EXPECT_EQ(b[6], 1);  // kind 1: position
  EXPECT_EQ(b[7], 0);
  EXPECT_EQ(std::vector<std::uint8_t>(b.begin() + 8, b.begin() + 12),
            (std::vector<std::uint8_t>{4, 3, 2, 1}));
  EXPECT_EQ(std::vector<std::uint8_t>(b.begin() + 12, b.begin() + 20),
            (std::vector<std::uint8_t>{0x88, 0x77, 0x66, 0x55, 0x44, 0x33, 0x22, 0x11}));
  // x = 1.0 is 0x3FF0000000000000; y = -2.5 is 0xC004000000000000.
  EXPECT_EQ(std::vector<std::uint8_t>(b.begin() + 20, b.begin() + 28),
            (std::vector<std::uint8_t>{0, 0, 0, 0, 0, 0, 0xF0, 0x3F}));
  EXPECT_EQ(std::vector<std::uint8_t>(b.begin() + 28, b.begin() + 36),
            (std::vector<std::uint8_t>{0, 0, 0, 0, 0, 0, 0x04, 0xC0}));
  EXPECT_EQ(b[76], 3);  // buttons: grab | dead-man
  EXPECT_EQ(b[80], 1);  // flags: has orientation
  EXPECT_EQ(std::vector<std::uint8_t>(b.begin() + 84, b.begin() + 88),
            (std::vector<std::uint8_t>{0xD4, 0xC3, 0xB2, 0xA1}));  // round_trip_ns
}

TEST(BridgePacket, PositionAndForceRoundTripBitForBit) {
  const PositionPacket p = sample_position();
  PositionPacket back;
  const std::vector<std::uint8_t> b = encoded(p);
  ASSERT_EQ(parse_position(b.data(), b.size(), &back), PacketError::none);
  EXPECT_EQ(back.header.version, kBridgeVersion);
  EXPECT_EQ(back.header.kind, PacketKind::position);
  EXPECT_EQ(back.header.sequence, p.header.sequence);
  EXPECT_EQ(back.header.sent_ns, p.header.sent_ns);
  EXPECT_EQ(back.position_mm, p.position_mm);  // 1e-300 too: no conversion on the way
  EXPECT_EQ(back.orientation_wxyz, p.orientation_wxyz);
  EXPECT_EQ(back.buttons, p.buttons);
  EXPECT_EQ(back.flags, p.flags);
  EXPECT_EQ(back.round_trip_ns, p.round_trip_ns);

  ForcePacket f;
  f.header.sequence = 0xFFFFFFFFu;
  f.header.sent_ns = 42;
  f.echo_sequence = 0x01020304u;
  f.echo_sent_ns = 0x1122334455667788ull;
  f.tick = (1ull << 40) + 7;
  f.force_n = Vec3d(-0.0, 3.25, -9.999999999999998);
  f.status = kForceRamping | kForceSilence;
  std::vector<std::uint8_t> fb(kBridgeMaxDatagramBytes);
  fb.resize(encode_force(f, fb.data()));
  ASSERT_EQ(fb.size(), kForcePacketBytes);
  ASSERT_EQ(fb.size(), 68u);
  EXPECT_EQ(fb[6], 2);  // kind 2: force
  ForcePacket fback;
  ASSERT_EQ(parse_force(fb.data(), fb.size(), &fback), PacketError::none);
  EXPECT_EQ(fback.header.sequence, f.header.sequence);
  EXPECT_EQ(fback.echo_sequence, f.echo_sequence);
  EXPECT_EQ(fback.echo_sent_ns, f.echo_sent_ns);
  EXPECT_EQ(fback.tick, f.tick);
  EXPECT_EQ(fback.force_n, f.force_n);
  EXPECT_TRUE(std::signbit(fback.force_n.x()));
  EXPECT_EQ(fback.status, f.status);
}

// Each malformed datagram gets its own error and leaves the output untouched.
TEST(BridgePacket, EachMalformedDatagramIsNamedAndChangesNothing) {
  const std::vector<std::uint8_t> good = encoded(sample_position());
  const auto parse = [](std::vector<std::uint8_t> bytes) {
    PositionPacket out;
    out.header.sequence = 77;
    const PacketError e = parse_position(bytes.data(), bytes.size(), &out);
    if (e != PacketError::none) {
      EXPECT_EQ(out.header.sequence, 77u) << packet_error_name(e);
    }
    return e;
  };
  EXPECT_EQ(parse({}), PacketError::too_short);
  EXPECT_EQ(parse(std::vector<std::uint8_t>(good.begin(), good.begin() + 19)),
            PacketError::too_short);
  EXPECT_EQ(parse(std::vector<std::uint8_t>(good.begin(), good.end() - 1)), PacketError::too_short);
  std::vector<std::uint8_t> longer = good;
  longer.push_back(0);
  EXPECT_EQ(parse(longer), PacketError::oversized);
  std::vector<std::uint8_t> magic = good;
  magic[0] = 'h';
  EXPECT_EQ(parse(magic), PacketError::bad_magic);
  std::vector<std::uint8_t> version = good;
  version[4] = 2;
  EXPECT_EQ(parse(version), PacketError::bad_version);
  std::vector<std::uint8_t> kind = good;
  kind[6] = 2;
  EXPECT_EQ(parse(kind), PacketError::wrong_kind);
  // A version-2 packet of another length is refused for its version, not its length.
  version.resize(100);
  EXPECT_EQ(parse(version), PacketError::bad_version);

  PositionPacket nan = sample_position();
  nan.position_mm.y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(parse(encoded(nan)), PacketError::not_finite);
  PositionPacket inf = sample_position();
  inf.orientation_wxyz[3] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(parse(encoded(inf)), PacketError::not_finite);
  PositionPacket doubled = sample_position();
  for (double& q : doubled.orientation_wxyz) q *= 2.0;
  EXPECT_EQ(parse(encoded(doubled)), PacketError::bad_orientation);
  // Without the orientation flag the quaternion is not looked at.
  doubled.flags = 0;
  EXPECT_EQ(parse(encoded(doubled)), PacketError::none);

  ForcePacket f;
  f.force_n.z() = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::uint8_t> fb(kBridgeMaxDatagramBytes);
  fb.resize(encode_force(f, fb.data()));
  ForcePacket out;
  EXPECT_EQ(parse_force(fb.data(), fb.size(), &out), PacketError::not_finite);
  EXPECT_EQ(parse_force(good.data(), good.size(), &out), PacketError::wrong_kind);
}

TEST(BridgePacket, EveryErrorHasAName) {
  for (int e = 0; e < kPacketErrorCount; ++e) {
    EXPECT_STRNE(packet_error_name(static_cast<PacketError>(e)), "unknown") << e;
  }
}

}  // namespace
}  // namespace hapvox::haptics
