#pragma once
// The bridge's reference client (what `hapvox device-sim` runs, what the tests and the
// latency bench use, and what an integrator copies): it plays a resampled trace through the
// device bridge as a device's servo loop would, one position packet per tick on its own
// absolute clock, and takes the force packets that come back: the first answer to each
// position is kept, with the round trip it took (its clock now minus the echoed send time),
// and the newest round trip rides in the next position packet so hapvox records it too.
//
// For tests it can impair its own stream, reproducibly: drop a fraction of the packets,
// swap a fraction with the next one (reordering) and send a fraction twice.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "haptics/bridge_key.h"
#include "haptics/bridge_packet.h"
#include "haptics/latency_histogram.h"
#include "haptics/trace.h"
#include "haptics/udp_socket.h"

namespace hapvox::haptics {

struct BridgeClientOptions {
  double drop_fraction = 0.0;              // packets never sent
  double reorder_fraction = 0.0;           // packets sent after the next one
  double duplicate_fraction = 0.0;         // packets sent twice
  std::uint64_t seed = 1;                  // of the impairments
  std::uint32_t buttons = kButtonDeadMan;  // held down throughout (released: no force)
  /// Stop sending for this long from this time into the trace (< 0: no pause), e.g. to
  /// test that a silent device has its force ramped out.
  double pause_at_s = -1.0;
  double pause_s = 0.0;
  /// After the trace, how long to keep taking answers before the end packet.
  double linger_s = 0.05;
  bool send_end = true;  // end the session when the trace is done
  /// The session's shared key (hapvox's --device-key): positions are tagged, and answers
  /// whose tag is wrong or missing are refused.
  std::optional<BridgeKey> key;
};

struct BridgeAnswer {
  bool answered = false;
  Vec3d force_n = Vec3d::Zero();
  std::uint32_t status = 0;
  std::uint64_t tick = 0;
  std::int64_t round_trip_ns = 0;
};

struct BridgeClientResult {
  std::vector<BridgeAnswer> answers;  // by sequence number = trace tick
  std::uint64_t sent = 0, dropped = 0, reordered = 0, duplicated = 0;
  std::uint64_t answered = 0;         // positions with an answer
  std::uint64_t force_packets = 0;    // every force packet that came back
  std::uint64_t malformed = 0;        // datagrams that were not force packets
  std::uint64_t unauthenticated = 0;  // keyed: answers with a wrong or missing tag
  LatencyHistogram round_trip;
  double wall_s = 0.0;
};

/// Plays `trace` (its positions in the device frame, one packet per tick at its rate) to
/// `to` from `socket`. Allocates its result before the first packet.
BridgeClientResult play_through_bridge(const ResampledTrace& trace, UdpSocket& socket,
                                       const SocketAddress& to,
                                       const BridgeClientOptions& options = {});

}  // namespace hapvox::haptics
