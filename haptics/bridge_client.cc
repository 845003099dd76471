#include "haptics/bridge_client.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <random>

#include "haptics/device.h"

namespace hapvox::haptics {
namespace {

using Clock = std::chrono::steady_clock;

std::uint64_t now_ns() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch())
          .count());
}

class Client {
 public:
  Client(UdpSocket& socket, const SocketAddress& to, const BridgeKey* key,
         BridgeClientResult& result)
      : socket_(socket), to_(to), key_(key), result_(result) {}

  void take_answers() {
    for (;;) {
      const long length = socket_.receive(buffer_, sizeof buffer_, nullptr);
      if (length < 0) return;
      ForcePacket force;
      const PacketError error =
          parse_force(buffer_, static_cast<std::size_t>(length), &force, key_);
      if (error != PacketError::none) {
        ++(error == PacketError::bad_tag ? result_.unauthenticated : result_.malformed);
        continue;
      }
      ++result_.force_packets;
      const std::uint64_t arrived = now_ns();
      if (force.echo_sequence >= result_.answers.size()) continue;
      BridgeAnswer& answer = result_.answers[force.echo_sequence];
      if (answer.answered) continue;  // a held tick's repeat: the first answer counts
      answer.answered = true;
      answer.force_n = force.force_n;
      answer.status = force.status;
      answer.tick = force.tick;
      answer.round_trip_ns = static_cast<std::int64_t>(arrived - force.echo_sent_ns);
      result_.round_trip.add(answer.round_trip_ns);
      last_round_trip_ns_ =
          static_cast<std::uint32_t>(std::min<std::int64_t>(answer.round_trip_ns, 0xFFFFFFFFll));
      ++result_.answered;
    }
  }

  void send(PositionPacket packet) {
    packet.header.sent_ns = now_ns();
    packet.round_trip_ns = last_round_trip_ns_;
    std::uint8_t bytes[kPositionPacketBytes + kBridgeTagBytes];
    const std::size_t size = encode_position(packet, bytes, key_);
    socket_.send_to(bytes, size, to_);
    ++result_.sent;
  }

 private:
  UdpSocket& socket_;
  const SocketAddress& to_;
  const BridgeKey* key_;
  BridgeClientResult& result_;
  std::uint32_t last_round_trip_ns_ = 0;
  std::uint8_t buffer_[kBridgeMaxDatagramBytes] = {};
};

}  // namespace

BridgeClientResult play_through_bridge(const ResampledTrace& trace, UdpSocket& socket,
                                       const SocketAddress& to,
                                       const BridgeClientOptions& options) {
  BridgeClientResult result;
  const std::size_t ticks = trace.position_mm.size();
  result.answers.resize(ticks + 1);  // the end packet's too
  Client client(socket, to, options.key ? &*options.key : nullptr, result);
  std::mt19937_64 random(options.seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const auto dt = std::chrono::nanoseconds(std::llround(1e9 / trace.rate_hz));
  const auto start = Clock::now() + std::chrono::milliseconds(2);
  std::optional<PositionPacket> held_back;  // a packet to send after the next one
  auto packet_for = [&](std::size_t k) {
    PositionPacket packet;
    packet.header.sequence = static_cast<std::uint32_t>(k);
    packet.position_mm = trace.position_mm[std::min(k, ticks - 1)];
    if (!trace.orientation.empty()) {  // the stylus orientation, where the trace has one
      const Eigen::Quaterniond& q = trace.orientation[std::min(k, ticks - 1)];
      packet.orientation_wxyz = {q.w(), q.x(), q.y(), q.z()};
      packet.flags |= kPositionHasOrientation;
    }
    packet.buttons = options.buttons;
    return packet;
  };
  for (std::size_t k = 0; k < ticks; ++k) {
    // Until this tick's deadline, take answers as they arrive (so a round trip is timed
    // when its answer comes, not when the next tick looks), then spin the last stretch.
    const Clock::time_point deadline = start + static_cast<std::int64_t>(k) * dt;
    for (auto now = Clock::now(); deadline - now > std::chrono::microseconds(100);
         now = Clock::now()) {
      if (socket.wait_readable(deadline - now - std::chrono::microseconds(100))) {
        client.take_answers();
      }
    }
    sleep_then_spin_until(deadline);
    client.take_answers();
    const double t = static_cast<double>(k) / trace.rate_hz;
    if (options.pause_at_s >= 0.0 && t >= options.pause_at_s &&
        t < options.pause_at_s + options.pause_s) {
      continue;
    }
    const PositionPacket packet = packet_for(k);
    const double roll = uniform(random);
    if (roll < options.drop_fraction) {
      ++result.dropped;
    } else if (roll < options.drop_fraction + options.reorder_fraction && !held_back) {
      held_back = packet;
      ++result.reordered;
      continue;
    } else {
      client.send(packet);
      if (roll > 1.0 - options.duplicate_fraction) {
        client.send(packet);
        ++result.duplicated;
      }
    }
    if (held_back) {
      client.send(*held_back);
      held_back.reset();
    }
  }
  if (held_back) client.send(*held_back);
  const auto linger_end =
      Clock::now() + std::chrono::nanoseconds(std::llround(options.linger_s * 1e9));
  while (Clock::now() < linger_end) {
    client.take_answers();
    socket.wait_readable(std::chrono::milliseconds(1));
  }
  if (options.send_end) {
    // The end packet may be lost like any other: sent a few times (the repeats are
    // duplicates to hapvox).
    PositionPacket end = packet_for(ticks);
    end.flags |= kPositionEndOfSession;
    for (int i = 0; i < 3; ++i) client.send(end);
    const auto end_wait = Clock::now() + std::chrono::milliseconds(20);
    while (Clock::now() < end_wait) {
      client.take_answers();
      socket.wait_readable(std::chrono::milliseconds(1));
    }
  }
  result.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  return result;
}

}  // namespace hapvox::haptics
