#pragma once
// The hand-off of surface changes from the force thread (producer) to the relaxation thread
// (consumer): a bounded lock-free SPSC queue from atomic_queue, plus coalescing on overflow.
//
// push() never blocks, locks or allocates. When the queue is full the change is merged into
// one pending change held by the producer: its sweep is extended from the first pending
// position to the newest (a capsule, which covers every sphere along a straight path), so
// no change is lost; the pending change goes out with the next push that finds room, or
// with flush(). Overflows and merges are counted.

#include <atomic_queue/atomic_queue.h>

#include <atomic>
#include <cstdint>

#include "engine/tool_force.h"

namespace hapvox::haptics {

class SurfaceChangeChannel {
 public:
  static constexpr unsigned kCapacity = 4096;

  /// Producer side. Returns false when the change had to be coalesced.
  bool push(const engine::SurfaceChange& change);
  /// Producer side: tries to send a pending coalesced change. True when none is left.
  bool flush();
  /// Consumer side. False when empty.
  bool pop(engine::SurfaceChange& change) { return queue_.try_pop(change); }

  /// Approximate number of queued changes (either side).
  unsigned depth() const { return queue_.was_size(); }
  std::uint64_t overflows() const { return overflows_.load(std::memory_order_relaxed); }
  bool has_pending() const { return pending_valid_; }

 private:
  atomic_queue::AtomicQueue2<engine::SurfaceChange, kCapacity, true, true, false, true> queue_;
  // Producer-only state.
  bool pending_valid_ = false;
  engine::SurfaceChange pending_;
  std::atomic<std::uint64_t> overflows_{0};
};

}  // namespace hapvox::haptics
