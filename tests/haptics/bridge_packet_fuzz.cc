// Fuzz target for the device bridge's packet parser (haptics/bridge_packet.h): any bytes are
// a packet or one PacketError; nothing is read past the datagram (ASan), nothing crashes,
// and an accepted packet encodes back to the same bytes. The position an accepted packet
// carries, arriving once amid a device held still, keeps every force sent finite, clamped
// and continuous (force_safety_check.h). The first byte picks the parser
// (bit 0 clear: position, set: force) and whether it checks a key's tags (bit 1: the
// fixed key below; an accepted keyed packet encodes back to its bytes, tag included).
//
// Built as a libFuzzer binary (bridge_fuzz) where the compiler has -fsanitize=fuzzer (clang).
// With HAPVOX_FUZZ_REPLAY (in haptics_tests, any compiler) a test feeds it seeded random
// mutations of a valid position and force packet.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "force_safety_check.h"
#include "haptics/bridge_packet.h"

namespace {

using namespace hapvox::haptics;  // NOLINT(build/namespaces)

const BridgeKey& fuzz_key() {
  static const BridgeKey key("hapvox bridge fuzz key");
  return key;
}

// An accepted packet is the bytes it was parsed from (the orientation of a position packet
// without the flag is carried as is: compared only when it is a number).
template <typename Packet>
void check_round_trip(const std::uint8_t* data, std::size_t size, const Packet& packet,
                      std::size_t (*encode)(const Packet&, std::uint8_t*, const BridgeKey*),
                      const BridgeKey* key, bool compare) {
  std::vector<std::uint8_t> again(kBridgeMaxDatagramBytes);
  const std::size_t n = encode(packet, again.data(), key);
  if (n != size) std::abort();
  if (compare && std::memcmp(again.data(), data, size) != 0) std::abort();
}

// The device rests at the seed packet's position (3.8 N in the test's spring) for 20 ticks, the
// packet's position comes for one tick, then the rest position again: a wild one (1e300 mm)
// must ramp the force out and back in, never step it.
void abort_unless_one_packet_is_safe(const Vec3d& position_mm) {
  const Vec3d rest_mm(10.0, -20.0, 30.5);
  std::vector<Vec3d> stream(60, rest_mm);
  stream[20] = position_mm;
  hapvox::testing::abort_unless_forces_safe(stream);
}

int fuzz_bridge_packet(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  // A copy of exactly the datagram's bytes: ASan sees any read past its end.
  const std::vector<std::uint8_t> datagram(data + 1, data + size);
  const std::uint8_t* bytes = datagram.data();
  const BridgeKey* key = (data[0] & 2) != 0 ? &fuzz_key() : nullptr;
  if ((data[0] & 1) == 0) {
    PositionPacket p;
    const PacketError e = parse_position(bytes, datagram.size(), &p, key);
    if (static_cast<int>(e) < 0 || static_cast<int>(e) >= kPacketErrorCount) std::abort();
    if (e == PacketError::none) {
      if (!p.position_mm.allFinite()) std::abort();
      abort_unless_one_packet_is_safe(p.position_mm);
      bool numbers = true;
      for (double q : p.orientation_wxyz) numbers = numbers && !std::isnan(q);
      check_round_trip(bytes, datagram.size(), p, encode_position, key, numbers);
    }
  } else {
    ForcePacket f;
    const PacketError e = parse_force(bytes, datagram.size(), &f, key);
    if (static_cast<int>(e) < 0 || static_cast<int>(e) >= kPacketErrorCount) std::abort();
    if (e == PacketError::none) {
      if (!f.force_n.allFinite()) std::abort();
      check_round_trip(bytes, datagram.size(), f, encode_force, key, true);
    }
  }
  return 0;
}

}  // namespace

// haptics_tests holds trace_fuzz's entry point too; there the test calls fuzz_bridge_packet.
#ifndef HAPVOX_FUZZ_REPLAY
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return fuzz_bridge_packet(data, size);
}
#endif

#ifdef HAPVOX_FUZZ_REPLAY

#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <string>

#include "fuzz_mutate.h"

namespace {

TEST(BridgeFuzz, MutationsOfPacketsParseOrAreCountedErrors) {
  PositionPacket p;
  p.header.sequence = 7;
  p.position_mm = Vec3d(10.0, -20.0, 30.5);
  p.flags = kPositionHasOrientation;
  ForcePacket f;
  f.force_n = Vec3d(0.5, 0.0, -1.0);
  // Each packet unkeyed and keyed (its tag appended), as the first byte picks them.
  std::string seeds[4];
  for (int s = 0; s < 4; ++s) {
    const BridgeKey* key = s >= 2 ? &fuzz_key() : nullptr;
    std::string& seed = seeds[s];
    seed.assign(kBridgeMaxDatagramBytes, '\0');
    auto* out = reinterpret_cast<std::uint8_t*>(seed.data());
    seed.resize(s % 2 == 1 ? encode_force(f, out, key) : encode_position(p, out, key));
  }
  std::mt19937_64 rng(20261204);
  int accepted = 0, refused = 0, keyed_accepted = 0, bad_tags = 0;
  for (int i = 0; i < 40000; ++i) {
    const int s = i % 4;
    const bool is_force = s % 2 == 1;
    const BridgeKey* key = s >= 2 ? &fuzz_key() : nullptr;
    // One keyed input in twenty is the seed itself: the right tag is taken.
    const std::string body =
        key != nullptr && i % 40 < 4 ? seeds[s] : hapvox::testing::mutate(seeds[s], rng);
    const std::string input = std::string(1, static_cast<char>(s)) + body;
    const auto* bytes = reinterpret_cast<const std::uint8_t*>(input.data());
    PositionPacket pp;
    ForcePacket ff;
    const PacketError e = is_force ? parse_force(bytes + 1, input.size() - 1, &ff, key)
                                   : parse_position(bytes + 1, input.size() - 1, &pp, key);
    if (key == nullptr) {
      (e == PacketError::none ? accepted : refused)++;
    } else {
      keyed_accepted += e == PacketError::none ? 1 : 0;
      bad_tags += e == PacketError::bad_tag ? 1 : 0;
      // A changed byte past the header is never taken with its old tag.
      if (e == PacketError::none) {
        EXPECT_EQ(body, seeds[s]) << i;
      }
    }
    fuzz_bridge_packet(bytes, input.size());
  }
  // Both outcomes occur: flips inside the numbers are accepted, length and header changes
  // refused; keyed, only the seeds themselves are taken, and flips are refused for their tag.
  EXPECT_GT(accepted, 1000);
  EXPECT_GT(refused, 1000);
  EXPECT_GE(keyed_accepted, 2000);
  EXPECT_GT(bad_tags, 500);
  std::printf("bridge fuzz corpus: %d accepted, %d refused; keyed %d accepted, %d bad tags\n",
              accepted, refused, keyed_accepted, bad_tags);
}

}  // namespace

#endif  // HAPVOX_FUZZ_REPLAY
