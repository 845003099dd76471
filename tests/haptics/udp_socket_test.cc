// The bridge's UDP transport on loopback: a packet there and its answer back, receiving that
// never waits, a datagram longer than the buffer reported at its real length, and every bad
// address spec as one exact line.

#include "haptics/udp_socket.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "haptics/bridge_packet.h"

namespace hapvox::haptics {
namespace {

TEST(UdpAddress, ParsesHostsAndPorts) {
  const UdpAddress v4 = parse_udp_address("udp:127.0.0.1:47001");
  EXPECT_EQ(v4.host, "127.0.0.1");
  EXPECT_EQ(v4.port, 47001);
  const UdpAddress v6 = parse_udp_address("udp:[::1]:9");
  EXPECT_EQ(v6.host, "::1");
  EXPECT_EQ(v6.port, 9);
  EXPECT_EQ(parse_udp_address("udp:localhost:0").port, 0);
}

TEST(UdpAddress, EachBadSpecIsOneLine) {
  const std::string usage = "expected udp:HOST:PORT (e.g. udp:127.0.0.1:47001 or udp:[::1]:47001)";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"tcp:127.0.0.1:1", usage},
      {"udp:127.0.0.1", usage},
      {"udp:::1:5", usage},
      {"udp:[::1]5", usage},
      {"udp::5", "no host (" + usage + ")"},
      {"udp:host:", "port '' is not a number in 0..65535"},
      {"udp:host:65536", "port '65536' is not a number in 0..65535"},
      {"udp:host:12x", "port '12x' is not a number in 0..65535"},
  };
  for (const auto& [spec, problem] : cases) {
    try {
      parse_udp_address(spec);
      ADD_FAILURE() << spec;
    } catch (const InputError& e) {
      EXPECT_EQ(e.source(), spec);
      EXPECT_EQ(e.problem(), problem) << spec;
    }
  }
  try {
    resolve_udp_address({"no-such-host.invalid", 1}, "--device");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), "--device");
    EXPECT_EQ(std::string(e.problem()).rfind("cannot resolve host 'no-such-host.invalid': ", 0), 0u)
        << e.problem();
  }
}

TEST(UdpSocket, APositionPacketGoesOverLoopbackAndItsAnswerComesBack) {
  UdpSocket hapvox_side = UdpSocket::bound({"127.0.0.1", 0}, "test");
  UdpSocket device_side = UdpSocket::bound({"127.0.0.1", 0}, "test");
  ASSERT_NE(hapvox_side.local_port(), 0);
  std::vector<std::uint8_t> buffer(kBridgeMaxDatagramBytes);
  // Nothing waiting: -1 at once, however long nothing comes.
  const auto before = std::chrono::steady_clock::now();
  EXPECT_EQ(hapvox_side.receive(buffer.data(), buffer.size(), nullptr), -1);
  EXPECT_LT(std::chrono::steady_clock::now() - before, std::chrono::milliseconds(100));

  PositionPacket p;
  p.header.sequence = 41;
  p.position_mm = Vec3d(1.0, 2.0, 3.0);
  std::vector<std::uint8_t> out(kBridgeMaxDatagramBytes);
  const std::size_t n = encode_position(p, out.data());
  const SocketAddress to_hapvox =
      resolve_udp_address({"127.0.0.1", hapvox_side.local_port()}, "test");
  ASSERT_TRUE(device_side.send_to(out.data(), n, to_hapvox));
  ASSERT_TRUE(hapvox_side.wait_readable(std::chrono::seconds(2)));
  SocketAddress sender;
  const long got = hapvox_side.receive(buffer.data(), buffer.size(), &sender);
  ASSERT_EQ(got, static_cast<long>(kPositionPacketBytes));
  PositionPacket in;
  ASSERT_EQ(parse_position(buffer.data(), static_cast<std::size_t>(got), &in), PacketError::none);
  EXPECT_EQ(in.position_mm, p.position_mm);

  // The answer goes to whoever sent: the device's socket.
  ForcePacket f;
  f.echo_sequence = in.header.sequence;
  f.force_n = Vec3d(0.0, 0.0, 1.5);
  const std::size_t m = encode_force(f, out.data());
  ASSERT_TRUE(hapvox_side.send_to(out.data(), m, sender));
  ASSERT_TRUE(device_side.wait_readable(std::chrono::seconds(2)));
  const long answer = device_side.receive(buffer.data(), buffer.size(), nullptr);
  ASSERT_EQ(answer, static_cast<long>(kForcePacketBytes));
  ForcePacket back;
  ASSERT_EQ(parse_force(buffer.data(), kForcePacketBytes, &back), PacketError::none);
  EXPECT_EQ(back.echo_sequence, 41u);
  EXPECT_EQ(back.force_n.z(), 1.5);
}

TEST(UdpSocket, ADatagramLongerThanTheBufferReportsItsRealLength) {
  UdpSocket receiver = UdpSocket::bound({"127.0.0.1", 0}, "test");
  UdpSocket sender = UdpSocket::bound({"127.0.0.1", 0}, "test");
  // A position packet with 1,416 bytes of padding after it.
  std::vector<std::uint8_t> big(1500, 0xAB);
  encode_position(PositionPacket{}, big.data());
  ASSERT_TRUE(sender.send_to(big.data(), big.size(),
                             resolve_udp_address({"127.0.0.1", receiver.local_port()}, "test")));
  ASSERT_TRUE(receiver.wait_readable(std::chrono::seconds(2)));
  std::vector<std::uint8_t> buffer(kBridgeMaxDatagramBytes + 1, 0);
  EXPECT_EQ(receiver.receive(buffer.data(), kBridgeMaxDatagramBytes, nullptr), 1500);
  EXPECT_EQ(buffer[kBridgeMaxDatagramBytes - 1], 0xAB);
  EXPECT_EQ(buffer[kBridgeMaxDatagramBytes], 0);  // nothing written past the capacity
  // The parser refuses it from its real length, reading no further than the header.
  PositionPacket p;
  EXPECT_EQ(parse_position(buffer.data(), 1500, &p), PacketError::oversized);
}

TEST(UdpSocket, APortInUseIsOneLine) {
  UdpSocket first = UdpSocket::bound({"127.0.0.1", 0}, "test");
  const std::uint16_t port = first.local_port();
  try {
    UdpSocket::bound({"127.0.0.1", port}, "--device");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.problem(),
              "cannot listen on 127.0.0.1:" + std::to_string(port) + ": Address already in use");
  }
}

// The bridge binds one sender: an address is the same host and port, whichever family the
// socket reports it in.
TEST(UdpSocket, SameEndpointIsTheSameHostAndPort) {
  const SocketAddress a = resolve_udp_address({"127.0.0.1", 47001}, "test");
  EXPECT_TRUE(same_endpoint(a, resolve_udp_address({"127.0.0.1", 47001}, "test")));
  EXPECT_FALSE(same_endpoint(a, resolve_udp_address({"127.0.0.1", 47002}, "test")));
  EXPECT_FALSE(same_endpoint(a, resolve_udp_address({"127.0.0.2", 47001}, "test")));
  // A dual-stack socket reports an IPv4 sender as ::ffff:127.0.0.1.
  const SocketAddress mapped = resolve_udp_address({"::ffff:127.0.0.1", 47001}, "test");
  EXPECT_TRUE(same_endpoint(a, mapped));
  EXPECT_TRUE(same_endpoint(mapped, a));
  const SocketAddress v6 = resolve_udp_address({"::1", 47001}, "test");
  EXPECT_TRUE(same_endpoint(v6, resolve_udp_address({"::1", 47001}, "test")));
  EXPECT_FALSE(same_endpoint(v6, a));
  EXPECT_FALSE(same_endpoint(v6, resolve_udp_address({"::1", 47002}, "test")));
  EXPECT_FALSE(same_endpoint(a, SocketAddress{}));
  EXPECT_EQ(endpoint_text(a), "127.0.0.1:47001");
  EXPECT_EQ(endpoint_text(v6), "[::1]:47001");
}

}  // namespace
}  // namespace hapvox::haptics
