// The device bridge's wire format: the documented bytes (little-endian, at their offsets),
// round trips, and every way a datagram is refused.

#include "haptics/bridge_packet.h"

#include <gtest/gtest.h>

#include <openssl/evp.h>
#include <openssl/hmac.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "engine/errors.h"

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

std::vector<std::uint8_t> tag_of(const BridgeKey& key, const std::string& data) {
  std::vector<std::uint8_t> tag(kBridgeTagBytes);
  key.sign(reinterpret_cast<const std::uint8_t*>(data.data()), data.size(), tag.data());
  return tag;
}

std::vector<std::uint8_t> from_hex(const std::string& hex) {
  std::vector<std::uint8_t> bytes;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2) {
    bytes.push_back(static_cast<std::uint8_t>(std::stoul(hex.substr(i, 2), nullptr, 16)));
  }
  return bytes;
}

// HMAC-SHA256 as RFC 4231 defines it (its test cases 1, 2 and 6: a key longer than a block
// is hashed first), and as OpenSSL's own HMAC() computes it for keys and messages of every
// length around SHA-256's 64-byte block.
TEST(BridgeKey, TagsAreHmacSha256) {
  EXPECT_EQ(tag_of(BridgeKey(std::string(20, '\x0b')), "Hi There"),
            from_hex("b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e9376c2e32cff7"));
  EXPECT_EQ(tag_of(BridgeKey("Jefe"), "what do ya want for nothing?"),
            from_hex("5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843"));
  EXPECT_EQ(tag_of(BridgeKey(std::string(131, '\xaa')),
                   "Test Using Larger Than Block-Size Key - Hash Key First"),
            from_hex("60e431591ee0b67f0d8a26aacbf5b77f8e0bc6213728c5140546040f0ee37f54"));
  std::mt19937 rng(27);
  for (const std::size_t key_bytes : {1u, 32u, 63u, 64u, 65u, 200u}) {
    for (const std::size_t data_bytes : {0u, 55u, 56u, 64u, 88u, 119u, 300u}) {
      std::string key(key_bytes, '\0'), data(data_bytes, '\0');
      for (char& c : key) c = static_cast<char>(rng());
      for (char& c : data) c = static_cast<char>(rng());
      std::vector<std::uint8_t> expected(kBridgeTagBytes);
      unsigned int length = 0;
      HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()),
           reinterpret_cast<const unsigned char*>(data.data()), data.size(), expected.data(),
           &length);
      ASSERT_EQ(length, kBridgeTagBytes);
      const BridgeKey bridge_key(key);
      ASSERT_EQ(tag_of(bridge_key, data), expected) << key_bytes << " " << data_bytes;
      const BridgeKey copy = bridge_key;  // a copy tags alike
      ASSERT_EQ(tag_of(copy, data), expected);
    }
  }
}

// A keyed packet is the unkeyed one's bytes and their tag; the receiver with the same key
// takes it, one with another key, or none, or a packet without its tag or with one bit of it
// changed, refuses it (bad_tag) and leaves the output as it was.
TEST(BridgeKey, KeyedPacketsCarryTheirTagAndOnlyTheRightKeyTakesThem) {
  const BridgeKey key("a shared secret"), other("another secret");
  const PositionPacket p = sample_position();
  const std::vector<std::uint8_t> plain = encoded(p);
  std::vector<std::uint8_t> keyed(kBridgeMaxDatagramBytes);
  keyed.resize(encode_position(p, keyed.data(), &key));
  ASSERT_EQ(keyed.size(), 120u);
  ASSERT_EQ(keyed.size(), position_packet_bytes(&key));
  EXPECT_TRUE(std::equal(plain.begin(), plain.end(), keyed.begin()));
  std::vector<std::uint8_t> tag(kBridgeTagBytes);
  key.sign(plain.data(), plain.size(), tag.data());
  EXPECT_TRUE(std::equal(tag.begin(), tag.end(), keyed.begin() + 88));
  EXPECT_TRUE(key.verify(plain.data(), plain.size(), tag.data()));

  PositionPacket back;
  ASSERT_EQ(parse_position(keyed.data(), keyed.size(), &back, &key), PacketError::none);
  EXPECT_EQ(back.header.sequence, p.header.sequence);
  EXPECT_EQ(back.position_mm, p.position_mm);
  const auto refused = [&](std::vector<std::uint8_t> bytes, const BridgeKey* with) {
    PositionPacket out;
    out.header.sequence = 77;
    const PacketError e = parse_position(bytes.data(), bytes.size(), &out, with);
    EXPECT_EQ(out.header.sequence, 77u);
    return e;
  };
  EXPECT_EQ(refused(keyed, &other), PacketError::bad_tag);
  EXPECT_EQ(refused(plain, &key), PacketError::bad_tag);  // missing
  for (const std::size_t at : {0u, 8u, 30u, 87u, 88u, 119u}) {
    std::vector<std::uint8_t> flipped = keyed;
    flipped[at] ^= 0x10;
    const PacketError e = refused(flipped, &key);
    EXPECT_NE(e, PacketError::none) << at;
    if (at >= 8) {  // past magic, version and kind
      EXPECT_EQ(e, PacketError::bad_tag) << at;
    }
  }
  // Lengths other than the keyed one keep their names; an unkeyed receiver sees a keyed
  // packet as oversized.
  EXPECT_EQ(refused(std::vector<std::uint8_t>(keyed.begin(), keyed.end() - 1), &key),
            PacketError::too_short);
  std::vector<std::uint8_t> longer = keyed;
  longer.push_back(0);
  EXPECT_EQ(refused(longer, &key), PacketError::oversized);
  EXPECT_EQ(refused(keyed, nullptr), PacketError::oversized);

  // Force packets alike: 100 bytes, the device's key checks hapvox's answers.
  ForcePacket f;
  f.echo_sequence = 5;
  f.force_n = Vec3d(0.25, -1.0, 3.0);
  std::vector<std::uint8_t> answer(kBridgeMaxDatagramBytes);
  answer.resize(encode_force(f, answer.data(), &key));
  ASSERT_EQ(answer.size(), 100u);
  ForcePacket fback;
  ASSERT_EQ(parse_force(answer.data(), answer.size(), &fback, &key), PacketError::none);
  EXPECT_EQ(fback.force_n, f.force_n);
  EXPECT_EQ(parse_force(answer.data(), answer.size(), &fback, &other), PacketError::bad_tag);
  answer.resize(kForcePacketBytes);
  EXPECT_EQ(parse_force(answer.data(), answer.size(), &fback, &key), PacketError::bad_tag);
}

// --device-key FILE: its bytes as they are; a missing, unreadable or empty file is one line
// naming it.
TEST(BridgeKey, AKeyFileIsItsBytesAndABadOneIsOneLineNamingIt) {
  const std::string dir = ::testing::TempDir();
  const std::string path = dir + "/bridge_test.key";
  std::ofstream(path, std::ios::binary) << std::string("key\n\0bytes", 10);
  const BridgeKey key = BridgeKey::from_file(path);
  EXPECT_EQ(tag_of(key, "data"), tag_of(BridgeKey(std::string("key\n\0bytes", 10)), "data"));
  const auto problem = [](const std::string& file) {
    try {
      BridgeKey::from_file(file);
    } catch (const InputError& e) {
      EXPECT_EQ(e.source(), file);
      return e.problem();
    }
    return std::string("no error");
  };
  EXPECT_EQ(problem(dir + "/no_such.key"), "cannot open file");
  const std::string empty = dir + "/empty.key";
  std::ofstream(empty).close();
  EXPECT_EQ(problem(empty),
            "the key file is empty (it holds the shared key's bytes, e.g. 32 from /dev/urandom)");
  std::filesystem::create_directories(dir + "/a_dir.key");
  EXPECT_EQ(problem(dir + "/a_dir.key"), "is a directory");
}

TEST(BridgePacket, EveryErrorHasAName) {
  for (int e = 0; e < kPacketErrorCount; ++e) {
    EXPECT_STRNE(packet_error_name(static_cast<PacketError>(e)), "unknown") << e;
  }
}

}  // namespace
}  // namespace hapvox::haptics
