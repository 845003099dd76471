#pragma once
// What a stream of sequence numbers did on the way: each arriving packet is fresh (newer
// than any before: use it), late (older than the newest, first seen now: reordered, too
// late to use) or a duplicate (seen before). Gaps count as lost until a late packet fills
// them. A 64-packet window remembers which older numbers arrived (as IPsec's anti-replay
// window does); older than that counts as late. Sequence numbers are u32 and wrap: the
// newer of two is the one less than 2^31 ahead. Plain counters: no allocation, no locks.

#include <cstdint>

namespace hapvox::haptics {

enum class Arrival { fresh, late, duplicate };

class SequenceWindow {
 public:
  /// Classifies packet `sequence` and counts it.
  Arrival arrive(std::uint32_t sequence);

  std::uint64_t received() const { return received_; }      // every packet seen
  std::uint64_t fresh() const { return fresh_; }            // used
  std::uint64_t late() const { return late_; }              // reordered: arrived after a newer one
  std::uint64_t duplicates() const { return duplicates_; }  // seen before
  /// Numbers skipped by fresh packets that have not arrived since (within the window).
  std::uint64_t lost() const { return lost_; }
  /// The newest sequence number (valid after the first packet).
  std::uint32_t newest() const { return newest_; }

 private:
  bool started_ = false;
  std::uint32_t newest_ = 0;
  std::uint64_t seen_ = 0;  // bit k: newest_ - k arrived
  std::uint64_t received_ = 0;
  std::uint64_t fresh_ = 0;
  std::uint64_t late_ = 0;
  std::uint64_t duplicates_ = 0;
  std::uint64_t lost_ = 0;
};

}  // namespace hapvox::haptics
