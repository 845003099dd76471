#pragma once
// What a stream of sequence numbers did on the way: each arriving packet is fresh (newer
// than any before: use it), late (older than the newest, first seen now: reordered, too
// late to use), a duplicate (seen before) or out of the window (too far from the newest to
// be this stream's: a forged or stray number, refused). Gaps count as lost until a late
// packet fills them. A 64-packet window remembers which older numbers arrived (as IPsec's
// anti-replay window does); older than that counts as late. Sequence numbers are u32 and
// wrap: the newer of two is the one less than 2^31 ahead. Plain counters: no allocation, no
// locks.
//
// The window: a number more than `max_jump` (+ the caller's allowance) ahead of the newest,
// or more than `max_jump` behind it, is out of the window. It neither moves the newest nor
// counts the numbers it skipped as lost, so one forged jump of 2^31 - 10 cannot make the
// real stream's next packets late, nor count two billion losses. The caller widens the
// jump for a device that went quiet while it kept counting (BridgeDevice: by what it may
// have sent in the time since its last fresh packet).

#include <cstdint>

namespace hapvox::haptics {

/// The default window: 1000 numbers, a second of a 1 kHz device's packets.
inline constexpr std::uint32_t kSequenceMaxJump = 1000;
/// No allowance takes a jump past 2^30 (half of "newer"): 12 days of a 1 kHz stream.
inline constexpr std::uint32_t kSequenceJumpCeiling = 1u << 30;

enum class Arrival { fresh, late, duplicate, out_of_window };

class SequenceWindow {
 public:
  explicit SequenceWindow(std::uint32_t max_jump = kSequenceMaxJump) : max_jump_(max_jump) {}

  /// Classifies packet `sequence` and counts it. `extra_jump`: how much further ahead than
  /// max_jump a fresh number may be this time.
  Arrival arrive(std::uint32_t sequence, std::uint32_t extra_jump = 0);

  std::uint64_t received() const { return received_; }      // every packet seen
  std::uint64_t fresh() const { return fresh_; }            // used
  std::uint64_t late() const { return late_; }              // reordered: arrived after a newer one
  std::uint64_t duplicates() const { return duplicates_; }  // seen before
  std::uint64_t out_of_window() const { return out_of_window_; }  // refused: too far off
  /// Numbers skipped by fresh packets that have not arrived since (within the window).
  std::uint64_t lost() const { return lost_; }
  /// The newest sequence number (valid after the first packet).
  std::uint32_t newest() const { return newest_; }
  std::uint32_t max_jump() const { return max_jump_; }

 private:
  std::uint32_t max_jump_;
  bool started_ = false;
  std::uint32_t newest_ = 0;
  std::uint64_t seen_ = 0;  // bit k: newest_ - k arrived
  std::uint64_t received_ = 0;
  std::uint64_t fresh_ = 0;
  std::uint64_t late_ = 0;
  std::uint64_t duplicates_ = 0;
  std::uint64_t out_of_window_ = 0;
  std::uint64_t lost_ = 0;
};

}  // namespace hapvox::haptics
