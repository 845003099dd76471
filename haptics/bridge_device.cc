#include "haptics/bridge_device.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "haptics/session.h"

namespace hapvox::haptics {
namespace {

using std::chrono::nanoseconds;

nanoseconds seconds_to_ns(double s) {
  return nanoseconds(static_cast<std::int64_t>(std::llround(std::max(0.0, s) * 1e9)));
}

std::uint64_t steady_ns(Device::Clock::time_point t) {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<nanoseconds>(t.time_since_epoch()).count());
}

}  // namespace

BridgeDevice::BridgeDevice(UdpSocket socket, const DeviceTransform& transform,
                           const BridgeOptions& options)
    : socket_(std::move(socket)),
      transform_(transform),
      options_(options),
      period_(seconds_to_ns(1.0 / options.rate_hz)),
      fresh_wait_(
          nanoseconds(std::llround(options.wait_periods * static_cast<double>(period_.count())))),
      silence_timeout_(seconds_to_ns(options.silence_timeout_s)),
      end_after_silence_(seconds_to_ns(options.end_after_silence_s)),
      window_(options.max_sequence_jump),
      created_(Clock::now()) {
  if (options_.peer) {
    peer_ = *options_.peer;
    bound_ = true;
  }
}

std::optional<SocketAddress> BridgeDevice::peer() const {
  if (!bound_) return std::nullopt;
  return peer_;
}

std::uint32_t BridgeDevice::jump_allowance(Clock::time_point now) const {
  if (!started_ || now <= last_fresh_) return 0;
  // What a device at up to twice the loop's rate may have sent since its newest packet came
  // (it kept counting through a silence); the window caps it (kSequenceJumpCeiling).
  const double since_s = std::chrono::duration<double>(now - last_fresh_).count();
  return static_cast<std::uint32_t>(
      std::min(2.0 * options_.rate_hz * since_s, static_cast<double>(kSequenceJumpCeiling)));
}

bool BridgeDevice::finished() const {
  if (ended_) return true;
  if (options_.stop != nullptr && options_.stop->load(std::memory_order_relaxed)) return true;
  if (options_.end_after_silence_s > 0.0) {
    const Clock::time_point since = started_ ? last_fresh_ : created_;
    if (Clock::now() - since > end_after_silence_) return true;
  }
  return false;
}

void BridgeDevice::take(const PositionPacket& packet, Clock::time_point now) {
  echo_ = Echo{packet.header.sequence, packet.header.sent_ns, now};
  has_echo_ = true;
  latest_ = packet;
  last_fresh_ = now;
  started_ = true;
  fresh_this_tick_ = true;
  if (packet.round_trip_ns > 0) counters_.round_trip.add(packet.round_trip_ns);
  if ((packet.flags & kPositionEndOfSession) != 0) {
    end_pending_ = true;  // the session ends once its tick has answered it
    counters_.ended_by_sender = true;
  }
}

bool BridgeDevice::drain(Clock::time_point now) {
  bool got_fresh = false;
  const std::uint32_t allowance = jump_allowance(now);
  // Up to the first fresh position: each gets a tick of its own (a backlog runs tick after
  // tick), so every position is stepped through the model in order. Bounded, so a flood of
  // stale, foreign or malformed datagrams cannot hold the force thread here.
  for (int i = 0; i < 256 && !got_fresh; ++i) {
    SocketAddress from;
    const long length = socket_.receive(buffer_, sizeof buffer_, &from);
    if (length < 0) break;
    ++counters_.datagrams;
    if (bound_ && !same_endpoint(from, peer_)) {  // not our device: not even read
      ++counters_.foreign;
      continue;
    }
    PositionPacket packet;
    const PacketError error =
        parse_position(buffer_, static_cast<std::size_t>(length), &packet, key());
    if (error == PacketError::bad_tag) {
      ++counters_.unauthenticated;
      continue;
    }
    if (error != PacketError::none) {
      ++counters_.malformed[static_cast<int>(error)];
      continue;
    }
    if (!bound_) {  // the first valid packet's sender is the session's device
      peer_ = from;
      bound_ = true;
    }
    if (window_.arrive(packet.header.sequence, allowance) == Arrival::fresh) {
      take(packet, now);
      got_fresh = true;
    }
  }
  counters_.fresh = window_.fresh();
  counters_.late = window_.late();
  counters_.duplicates = window_.duplicates();
  counters_.lost = window_.lost();
  counters_.out_of_window = window_.out_of_window();
  return got_fresh;
}

Device::Clock::time_point BridgeDevice::wait_for_tick(std::size_t, Clock::time_point) {
  const bool last_was_fresh = fresh_this_tick_;
  fresh_this_tick_ = false;
  has_echo_ = false;
  if (!started_) {
    // The first position starts the session; wait in slices so a stop or the end-of-silence
    // timeout ends the wait.
    while (!started_) {
      if (finished()) return Clock::now();
      if (socket_.wait_readable(std::chrono::milliseconds(10))) drain(Clock::now());
    }
    last_tick_ = last_fresh_;
    return last_tick_;
  }
  if (ended_) return Clock::now();
  if (!options_.device_paced) {
    const Clock::time_point due = last_tick_ + period_;
    sleep_then_spin_until(due);
    drain(Clock::now());
    last_tick_ = due;
    return due;
  }
  // After a fresh position the next may be up to half a period late; after a held tick,
  // the loop keeps its own rate.
  const nanoseconds wait = last_was_fresh ? fresh_wait_ : period_;
  const Clock::time_point timeout = last_tick_ + wait;
  for (;;) {
    const Clock::time_point now = Clock::now();
    if (drain(now)) {
      last_tick_ = now;
      return now;
    }
    if (now >= timeout) {
      last_tick_ = timeout;
      return timeout;
    }
    socket_.wait_readable(timeout - now);
  }
}

void BridgeDevice::read(std::size_t tick, DeviceReading& reading) {
  reading.time_s = static_cast<double>(tick) / options_.rate_hz;
  reading.position_mm = latest_.position_mm;
  if ((latest_.flags & kPositionHasOrientation) != 0) {
    reading.orientation_wxyz = latest_.orientation_wxyz;  // checked a unit quaternion
  }
  reading.buttons = latest_.buttons;
  reading.sequence = latest_.header.sequence;
  reading.holding = !fresh_this_tick_;
  const bool was_silent = silent_;
  silent_ = !fresh_this_tick_ && last_tick_ - last_fresh_ > silence_timeout_;
  if (silent_ && !was_silent) ++counters_.silences;
  reading.silent = silent_;
  reading.released = (latest_.buttons & kButtonDeadMan) == 0;
  if (reading.holding) ++counters_.held_ticks;
  if (reading.silent) ++counters_.silent_ticks;
  if (reading.released) ++counters_.released_ticks;
}

void BridgeDevice::send(std::size_t tick, const Vec3d& force_device_n, const TickRecord& row,
                        bool fault) {
  ForcePacket answer;
  answer.header.kind = PacketKind::force;
  answer.tick = tick;
  answer.force_n = force_device_n;
  answer.status = (row.force_scale < 1.0 ? kForceRamping : 0u) |
                  (row.clamped != 0 ? kForceClamped : 0u) | (fault ? kForceFault : 0u) |
                  (silent_ ? kForceSilence : 0u) |
                  ((latest_.buttons & kButtonDeadMan) == 0 ? kForceReleased : 0u);
  // A held tick answers the newest position again, so a device whose packets are being
  // lost still hears the force ramp out.
  const Clock::time_point now = Clock::now();
  answer.header.sequence = answer_sequence_++;
  answer.header.sent_ns = steady_ns(now);
  answer.echo_sequence = latest_.header.sequence;
  answer.echo_sent_ns = latest_.header.sent_ns;
  std::uint8_t bytes[kForcePacketBytes + kBridgeTagBytes];
  const std::size_t size = encode_force(answer, bytes, key());
  if (socket_.send_to(bytes, size, peer_)) {
    ++counters_.answers;
  } else {
    ++counters_.send_failures;
  }
  if (has_echo_) {
    counters_.answer.add(std::chrono::duration_cast<nanoseconds>(now - echo_.arrived).count());
  }
  has_echo_ = false;
  if (end_pending_) ended_ = true;
}

}  // namespace hapvox::haptics
