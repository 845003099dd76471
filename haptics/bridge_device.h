#pragma once
// The device bridge (docs/formats.md, "Device bridge packets"): a device program anywhere on
// the network streams position packets over UDP; each fresh position gets a tick of its own
// (in sequence order; a backlog runs tick after tick), answered with that tick's force. The device
// paces the loop: a tick starts as soon as a fresh position arrives, so the answer leaves within
// the tick's compute time (no wait for a 1 ms tick boundary). A position that does not come
// within 1.5 periods of the last tick makes a tick on the held position (the loop keeps its rate
// through lost packets; the next periods at 1 period each); after `silence_timeout_s` without a
// fresh position the tick is "silent" and the loop ramps the force out (haptics/replay.h,
// ForceRamp): the force is zero at most silence_timeout_s + ramp_in_s after the last
// position, and ramps back in when positions come again. A released dead-man button does
// the same. Loss, reordering, duplicates and malformed datagrams are counted, never fatal.
//
// Whom it trusts (docs/formats.md, "Who may drive the tool"): one device per session. The
// first sender of a valid packet (or the one `BridgeOptions::peer` names) is bound for the
// session: datagrams from any other address or port are counted (`foreign`) and dropped
// unread, never answered, and answers go to the bound device alone. Sequence numbers are
// judged within a window (haptics/bridge_sequence.h), so a stray or forged number far from
// the stream's is refused (`out_of_window`) and the real stream goes on undisturbed. With a
// key (`BridgeOptions::key`) every packet both ways carries an HMAC-SHA256 tag, and one
// whose tag is wrong or missing is refused (`unauthenticated`) before anything in it is
// used, the binding included.
//
// wait_for_tick(), read() and send() run on the force thread: ppoll, recvfrom and sendto on
// one non-blocking socket, no locks, no allocation, no exceptions (a key's tags are checked
// and made there too: haptics/bridge_key.h says why that allocates nothing).

#include <atomic>
#include <cstdint>
#include <optional>

#include "haptics/bridge_key.h"
#include "haptics/bridge_packet.h"
#include "haptics/bridge_sequence.h"
#include "haptics/device.h"
#include "haptics/latency_histogram.h"
#include "haptics/udp_socket.h"

namespace hapvox::haptics {

struct BridgeOptions {
  double rate_hz = 1000.0;  // the loop's rate while it runs on held positions
  /// A tick waits this many periods after the last tick for a fresh position, then runs on
  /// the held one.
  double wait_periods = 1.5;
  /// No fresh position for this long: silent ticks, the force ramps out.
  double silence_timeout_s = 0.01;
  /// The session ends after this long without a fresh position (0: never); before the
  /// first position, after this long waiting for it.
  double end_after_silence_s = 5.0;
  /// Set by the application (a signal handler, a window's close) to end the session.
  const std::atomic<bool>* stop = nullptr;
  /// true: a position starts its tick at once. false: ticks keep the loop's own clock and
  /// take what arrived since the last (a position waits up to a period for its answer): the
  /// naive design, kept as `hapvox bench bridge`'s baseline.
  bool device_paced = true;
  /// The device's address and port: only its datagrams are taken (none: the first sender
  /// of a valid packet is bound for the session).
  std::optional<SocketAddress> peer;
  /// A shared key: positions must carry its tag, answers carry it (none: untagged packets).
  std::optional<BridgeKey> key;
  /// The sequence window: a position more than this many numbers ahead of the newest (plus
  /// twice the loop's rate times the time since the newest came, for a device that kept
  /// counting through a silence) or behind it is refused.
  std::uint32_t max_sequence_jump = kSequenceMaxJump;
};

/// What the bridge saw, for the session (read after the loop has joined its threads).
struct BridgeCounters {
  std::uint64_t datagrams = 0;  // everything that arrived
  std::uint64_t fresh = 0;      // positions used by a tick
  std::uint64_t late = 0;       // reordered: older than a position already used
  std::uint64_t duplicates = 0;
  std::uint64_t lost = 0;           // sequence numbers never seen (within the 64-packet window)
  std::uint64_t out_of_window = 0;  // sequence numbers too far from the stream's: refused
  std::uint64_t foreign = 0;        // datagrams from a sender other than the bound device: dropped
  std::uint64_t unauthenticated = 0;  // keyed: a wrong or missing tag (PacketError::bad_tag)
  std::uint64_t malformed[kPacketErrorCount] = {};  // by PacketError (bad_tag: above)
  std::uint64_t held_ticks = 0;                     // ticks without a fresh position
  std::uint64_t silent_ticks = 0;    // ticks past the silence timeout (force ramping out)
  std::uint64_t silences = 0;        // times the device fell silent
  std::uint64_t released_ticks = 0;  // ticks with the dead-man released
  std::uint64_t answers = 0;         // force packets sent
  std::uint64_t send_failures = 0;
  bool ended_by_sender = false;  // an end-of-session packet came
  LatencyHistogram round_trip;   // the sender's reported round trips
  LatencyHistogram answer;       // a position's arrival to its force leaving, here
};

class BridgeDevice final : public Device {
 public:
  BridgeDevice(UdpSocket socket, const DeviceTransform& transform, const BridgeOptions& options);

  double rate_hz() const override { return options_.rate_hz; }
  std::size_t tick_count() const override { return kUnbounded; }
  const DeviceTransform& transform() const override { return transform_; }
  /// Packets may carry the stylus orientation (kPositionHasOrientation): the session records
  /// it per tick, the identity for a packet without one.
  bool reports_orientation() const override { return true; }
  Clock::time_point wait_for_tick(std::size_t tick, Clock::time_point deadline) override;
  void read(std::size_t tick, DeviceReading& reading) override;
  void send(std::size_t tick, const Vec3d& force_device_n, const TickRecord& row,
            bool fault) override;
  bool finished() const override;

  const BridgeCounters& counters() const { return counters_; }
  std::uint16_t local_port() const { return socket_.local_port(); }
  double silence_timeout_s() const { return options_.silence_timeout_s; }
  /// The device the session is bound to (none before its first valid packet).
  std::optional<SocketAddress> peer() const;
  bool keyed() const { return options_.key.has_value(); }

 private:
  // Takes waiting datagrams up to the first fresh position; true when there was one.
  bool drain(Clock::time_point now);
  void take(const PositionPacket& packet, Clock::time_point now);
  // How much further than max_sequence_jump a fresh number may be now.
  std::uint32_t jump_allowance(Clock::time_point now) const;
  const BridgeKey* key() const { return options_.key ? &*options_.key : nullptr; }

  struct Echo {
    std::uint32_t sequence = 0;
    std::uint64_t sent_ns = 0;
    Clock::time_point arrived;
  };

  UdpSocket socket_;
  DeviceTransform transform_;
  BridgeOptions options_;
  // The options' durations, converted once (the force thread reads them every tick).
  std::chrono::nanoseconds period_;
  std::chrono::nanoseconds fresh_wait_;         // wait_periods periods: after a fresh position
  std::chrono::nanoseconds silence_timeout_;    // silence_timeout_s
  std::chrono::nanoseconds end_after_silence_;  // end_after_silence_s (0: never)
  SequenceWindow window_;
  BridgeCounters counters_;
  PositionPacket latest_;     // the newest fresh position
  SocketAddress peer_;        // the bound device: where positions come from, forces go
  bool bound_ = false;        // peer_ is set (options.peer, or a first valid packet)
  bool started_ = false;      // a first position came
  bool end_pending_ = false;  // an end-of-session packet came: its tick runs, then the end
  bool ended_ = false;
  bool fresh_this_tick_ = false;
  bool silent_ = false;
  Clock::time_point created_;
  Clock::time_point last_tick_;
  Clock::time_point last_fresh_;
  Echo echo_;  // the position this tick answers
  bool has_echo_ = false;
  std::uint32_t answer_sequence_ = 0;
  std::uint8_t buffer_[kBridgeMaxDatagramBytes] = {};
};

}  // namespace hapvox::haptics
