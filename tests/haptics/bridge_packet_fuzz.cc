// Fuzz target for the device bridge's packet parser (haptics/bridge_packet.h): any bytes are
// a packet or one PacketError; nothing is read past the datagram (ASan), nothing crashes,
// and an accepted packet encodes back to the same bytes. The first byte picks the parser
// (even: position, odd: force).
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

#include "haptics/bridge_packet.h"

namespace {

using namespace hapvox::haptics;  // NOLINT(build/namespaces)

// An accepted packet is the bytes it was parsed from (the orientation of a position packet
// without the flag is carried as is: compared only when it is a number).
template <typename Packet>
void check_round_trip(const std::uint8_t* data, std::size_t size, const Packet& packet,
                      std::size_t (*encode)(const Packet&, std::uint8_t*), bool compare) {
  std::vector<std::uint8_t> again(kBridgeMaxDatagramBytes);
  const std::size_t n = encode(packet, again.data());
  if (n != size) std::abort();
  if (compare && std::memcmp(again.data(), data, size) != 0) std::abort();
}

int fuzz_one_input(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  // A copy of exactly the datagram's bytes: ASan sees any read past its end.
  const std::vector<std::uint8_t> datagram(data + 1, data + size);
  const std::uint8_t* bytes = datagram.data();
  if ((data[0] & 1) == 0) {
    PositionPacket p;
    const PacketError e = parse_position(bytes, datagram.size(), &p);
    if (static_cast<int>(e) < 0 || static_cast<int>(e) >= kPacketErrorCount) std::abort();
    if (e == PacketError::none) {
      if (!p.position_mm.allFinite()) std::abort();
      bool numbers = true;
      for (double q : p.orientation_wxyz) numbers = numbers && !std::isnan(q);
      check_round_trip(bytes, datagram.size(), p, encode_position, numbers);
    }
  } else {
    ForcePacket f;
    const PacketError e = parse_force(bytes, datagram.size(), &f);
    if (static_cast<int>(e) < 0 || static_cast<int>(e) >= kPacketErrorCount) std::abort();
    if (e == PacketError::none) {
      if (!f.force_n.allFinite()) std::abort();
      check_round_trip(bytes, datagram.size(), f, encode_force, true);
    }
  }
  return 0;
}

}  // namespace

// haptics_tests holds trace_fuzz's entry point too; there the test calls fuzz_one_input.
#ifndef HAPVOX_FUZZ_REPLAY
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return fuzz_one_input(data, size);
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
  std::string position(kBridgeMaxDatagramBytes, '\0'), force(kBridgeMaxDatagramBytes, '\0');
  position.resize(encode_position(p, reinterpret_cast<std::uint8_t*>(position.data())));
  force.resize(encode_force(f, reinterpret_cast<std::uint8_t*>(force.data())));
  std::mt19937_64 rng(20261204);
  int accepted = 0, refused = 0;
  for (int i = 0; i < 20000; ++i) {
    const bool is_force = i % 2 == 1;
    const std::string input = std::string(1, is_force ? '\1' : '\0') +
                              hapvox::testing::mutate(is_force ? force : position, rng);
    const auto* bytes = reinterpret_cast<const std::uint8_t*>(input.data());
    PositionPacket pp;
    ForcePacket ff;
    const PacketError e = is_force ? parse_force(bytes + 1, input.size() - 1, &ff)
                                   : parse_position(bytes + 1, input.size() - 1, &pp);
    (e == PacketError::none ? accepted : refused)++;
    fuzz_one_input(bytes, input.size());
  }
  // Both outcomes occur: flips inside the numbers are accepted, length and header changes
  // refused.
  EXPECT_GT(accepted, 1000);
  EXPECT_GT(refused, 1000);
  std::printf("bridge fuzz corpus: %d accepted, %d refused\n", accepted, refused);
}

}  // namespace

#endif  // HAPVOX_FUZZ_REPLAY
