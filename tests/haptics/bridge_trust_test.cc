// Who may drive the tool through the device bridge (docs/formats.md, "Who may drive the
// tool"), end to end on loopback in one process: the device the bridge bound is the only
// sender it takes and answers; a forged sequence jump is refused and the device's stream goes
// on; with a key, only rightly tagged packets are taken, and checking them allocates nothing
// on the force thread (OpenSSL's allocations counted too).

#include <gtest/gtest.h>
#include <openssl/crypto.h>

#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "bridge_run.h"

namespace hapvox::haptics {
namespace {

using bridge_testing::BridgeRun;
using bridge_testing::BridgeRunSetup;
using bridge_testing::lockstep_forces;
using bridge_testing::press_ticks;
using bridge_testing::run_bridge_with;
using bridge_testing::temp_path;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

// OpenSSL's allocations, counted as the force thread's (installed before main, before
// OpenSSL allocates anything; CRYPTO_set_mem_functions refuses once it has).
void* counted_malloc(std::size_t n, const char*, int) {
  ++testing::allocations_on_this_thread;
  return std::malloc(n);
}
void* counted_realloc(void* p, std::size_t n, const char*, int) {
  ++testing::allocations_on_this_thread;
  return std::realloc(p, n);
}
void counted_free(void* p, const char*, int) { std::free(p); }
const bool g_openssl_allocations_counted =
    CRYPTO_set_mem_functions(counted_malloc, counted_realloc, counted_free) == 1;

// A forger's position: the tool 13.5 mm deep in the block (if a tick used it, the force
// would jump to the device's limit), the dead-man held.
const Vec3d kForgedMm(24.0, 24.0, 10.0);

PositionPacket forged(std::uint32_t sequence) {
  PositionPacket p;
  p.header.sequence = sequence;
  p.position_mm = kForgedMm;
  p.buttons = kButtonDeadMan;
  return p;
}

void send_packet(UdpSocket& from, const SocketAddress& to, const PositionPacket& p,
                 const BridgeKey* key = nullptr) {
  std::uint8_t bytes[kPositionPacketBytes + kBridgeTagBytes];
  from.send_to(bytes, encode_position(p, bytes, key), to);
}

// The client's sequence number about now (it sends number k at k ms after it starts).
std::uint32_t about_now(Clock::time_point start) {
  return static_cast<std::uint32_t>(
      std::chrono::duration_cast<milliseconds>(Clock::now() - start).count());
}

// Whether any tick of the session used the forged position.
bool session_used_forged(const std::string& session) {
  const std::vector<double> p = read_session_column(session, "/device_position_mm");
  for (std::size_t k = 0; k + 2 < p.size(); k += 3) {
    if (Vec3d(p[k], p[k + 1], p[k + 2]) == kForgedMm) return true;
  }
  return false;
}

// The device's stream went through as if nobody else had sent: every position fresh and
// answered, none late or lost, and the device ended the session.
void expect_device_undisturbed(const BridgeRun& run, const ResampledTrace& ticks) {
  const std::uint64_t n = ticks.position_mm.size();
  EXPECT_EQ(run.client.answered, run.client.sent - 2);  // the end packet's two repeats
  EXPECT_EQ(run.bridge.fresh, n + 1);
  EXPECT_EQ(run.bridge.late, 0u);
  EXPECT_EQ(run.bridge.lost, 0u);
  EXPECT_TRUE(run.bridge.ended_by_sender);
  EXPECT_GE(run.summary.ticks, n);
  ASSERT_TRUE(run.peer.has_value());
  EXPECT_EQ(endpoint_text(*run.peer), "127.0.0.1:" + std::to_string(run.client_port));
  EXPECT_EQ(run.force_thread_allocations, 0u);
}

// Issue 27's defect: a packet from a second loopback port took the tool and every later
// answer. Now the device that sent first is bound: the intruder's packets (numbers in the
// window, the defect's jump of 2^31 - 10, an end of session) are counted and dropped
// unread, and it never hears back.
TEST(BridgeDevice, ASecondSendersPacketsNeitherMoveTheToolNorGetAnAnswer) {
  const ResampledTrace ticks = press_ticks(0.3);
  BridgeRunSetup setup;
  std::uint64_t intruder_sent = 0, intruder_heard = 0;
  setup.beside = [&](UdpSocket&, const SocketAddress& to) {
    const Clock::time_point start = Clock::now();
    UdpSocket intruder = UdpSocket::bound({"127.0.0.1", 0}, "intruder");
    std::this_thread::sleep_for(milliseconds(200));  // the device is bound by now
    std::uint8_t in[kBridgeMaxDatagramBytes];
    for (int i = 0; i < 60; ++i) {
      const std::uint32_t now = about_now(start);
      PositionPacket p = forged(i % 3 == 0   ? now + 2
                                : i % 3 == 1 ? now + (1u << 31) - 10
                                             : now + (1u << 30));
      if (i == 59) p.flags |= kPositionEndOfSession;
      send_packet(intruder, to, p);
      ++intruder_sent;
      std::this_thread::sleep_for(milliseconds(3));
      while (intruder.receive(in, sizeof in, nullptr) >= 0) ++intruder_heard;
    }
    for (int i = 0; i < 100; ++i) {
      if (intruder.wait_readable(milliseconds(1))) {
        while (intruder.receive(in, sizeof in, nullptr) >= 0) ++intruder_heard;
      }
    }
  };
  const std::string path = temp_path("bridge_intruder.h5");
  const BridgeRun run = run_bridge_with(ticks, setup, path);
  EXPECT_EQ(intruder_heard, 0u);
  EXPECT_EQ(run.bridge.foreign, intruder_sent);
  EXPECT_EQ(run.bridge.out_of_window, 0u);  // not even read
  EXPECT_FALSE(session_used_forged(path));
  expect_device_undisturbed(run, ticks);
}

// A named peer (--device-peer) is the only sender even when another sends first.
TEST(BridgeDevice, ANamedPeerIsTheOnlySenderEvenWhenAnotherSendsFirst) {
  const ResampledTrace ticks = press_ticks(0.1);
  BridgeRunSetup setup;
  setup.client_is_named_peer = true;
  std::uint64_t early_sent = 0;
  UdpSocket early = UdpSocket::bound({"127.0.0.1", 0}, "early");
  setup.beside = [&](UdpSocket&, const SocketAddress& to) {
    for (std::uint32_t i = 0; i < 50; ++i, ++early_sent) send_packet(early, to, forged(i));
  };
  const std::string path = temp_path("bridge_named_peer.h5");
  const BridgeRun run = run_bridge_with(ticks, setup, path);
  EXPECT_EQ(run.bridge.foreign, early_sent);
  EXPECT_FALSE(session_used_forged(path));
  expect_device_undisturbed(run, ticks);
}

// A forged jump from the device's own address (what a peer binding cannot stop): 2^30 and
// 2^31 - 110 ahead, 2^30 behind. Each is refused out of the window; the device's next
// packets are not late, nothing counts as lost, no tick uses the forged position.
TEST(BridgeDevice, AForgedSequenceJumpLeavesTheDevicesStreamAlone) {
  const ResampledTrace ticks = press_ticks(0.3);
  BridgeRunSetup setup;
  setup.beside = [&](UdpSocket& device, const SocketAddress& to) {
    const Clock::time_point start = Clock::now();
    for (const std::uint32_t jump : {1u << 30, (1u << 31) - 110u, 0u - (1u << 30)}) {
      std::this_thread::sleep_for(milliseconds(150));
      send_packet(device, to, forged(about_now(start) + jump));
    }
  };
  const std::string path = temp_path("bridge_jump.h5");
  const BridgeRun run = run_bridge_with(ticks, setup, path);
  EXPECT_EQ(run.bridge.out_of_window, 3u);
  EXPECT_EQ(run.bridge.foreign, 0u);
  EXPECT_FALSE(session_used_forged(path));
  expect_device_undisturbed(run, ticks);
}

// With a key, the device's own address is not enough: packets from it with another key's
// tag, or none, are refused (unauthenticated) and move nothing; the device's tagged stream
// gets the lockstep replay's forces, tagged (the client checks them), and checking and
// tagging allocate nothing on the force thread, in OpenSSL either.
TEST(BridgeDevice, AKeyedBridgeTakesOnlyRightlyTaggedPackets) {
  ASSERT_TRUE(g_openssl_allocations_counted);
  const ResampledTrace ticks = press_ticks(0.3);
  const std::vector<Vec3d> expected = lockstep_forces(ticks);
  const BridgeKey key("the device's key"), wrong("someone else's key");
  BridgeRunSetup setup;
  setup.bridge.key = key;
  setup.client.key = key;
  setup.beside = [&](UdpSocket& device, const SocketAddress& to) {
    const Clock::time_point start = Clock::now();
    std::this_thread::sleep_for(milliseconds(200));
    for (int i = 0; i < 40; ++i) {  // numbers just ahead of the device's: fresh if taken
      send_packet(device, to, forged(about_now(start) + 3), i % 2 == 0 ? &wrong : nullptr);
      std::this_thread::sleep_for(milliseconds(2));
    }
  };
  const std::string path = temp_path("bridge_keyed.h5");
  const BridgeRun run = run_bridge_with(ticks, setup, path);
  EXPECT_EQ(run.bridge.unauthenticated, 40u);
  EXPECT_EQ(run.bridge.out_of_window, 0u);
  EXPECT_EQ(run.client.unauthenticated, 0u);
  EXPECT_EQ(run.client.malformed, 0u);
  EXPECT_FALSE(session_used_forged(path));
  expect_device_undisturbed(run, ticks);
  std::size_t compared = 0;
  for (std::size_t k = 100; k < ticks.position_mm.size(); ++k) {
    const BridgeAnswer& answer = run.client.answers[k];
    if (!answer.answered || (answer.status & kForceRamping) != 0) continue;
    ++compared;
    ASSERT_EQ(answer.force_n, expected[k]) << "sequence " << k;
  }
  EXPECT_GE(compared, 200u);
}

// A device with the wrong key never starts the session: every packet refused, none
// answered, no tick, nobody bound.
TEST(BridgeDevice, ADeviceWithTheWrongKeyIsNeverAnswered) {
  const ResampledTrace ticks = press_ticks(0.0);
  BridgeRunSetup setup;
  setup.bridge.key = BridgeKey("the right key");
  setup.bridge.end_after_silence_s = 2.0;  // the session ends, never having started
  setup.client.key = BridgeKey("the wrong key");
  const BridgeRun run = run_bridge_with(ticks, setup, temp_path("bridge_wrong_key.h5"));
  EXPECT_GT(run.client.sent, 500u);
  EXPECT_EQ(run.bridge.unauthenticated, run.client.sent);
  EXPECT_EQ(run.bridge.fresh, 0u);
  EXPECT_EQ(run.client.force_packets, 0u);
  EXPECT_EQ(run.summary.ticks, 0u);
  EXPECT_FALSE(run.peer.has_value());
}

}  // namespace
}  // namespace hapvox::haptics
