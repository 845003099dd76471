#pragma once
// The hand-off of surface changes from the force thread (producer) to the relaxation thread
// (consumer): a bounded SPSC ring in which neither side waits (haptics/spsc_ring.h), plus
// coalescing on overflow.
//
// push() never blocks, locks or allocates. When the queue is full the change is merged into
// one pending change held by the producer: its sweep is extended from the first pending
// position to the newest (a capsule, which covers every sphere along a straight path), so
// no change is lost; the pending change goes out with the next push that finds room, or
// with flush(). Overflows and merges are counted.
//
// An idle consumer sleeps in wait_for_arrival() instead of polling: every change that
// enters the queue bumps an arrival counter and notifies it (C++20 atomic wait/notify: on
// Linux a futex; the producer never blocks, and pays a wake-up system call only when the
// consumer is asleep, once per idle-to-busy transition).

#include <atomic>
#include <cstdint>

#include "engine/surface_change.h"
#include "haptics/spsc_ring.h"

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
  unsigned depth() const { return static_cast<unsigned>(queue_.was_size()); }
  std::uint64_t overflows() const { return overflows_.load(std::memory_order_relaxed); }
  bool has_pending() const { return pending_valid_; }

  /// Changes that entered the queue so far (wraps around; compare for equality only).
  std::uint32_t arrivals() const { return arrivals_.load(std::memory_order_acquire); }
  /// Consumer side: sleeps while arrivals() == seen. Read `seen` before finding the queue
  /// empty, so a change pushed in between is never slept through.
  void wait_for_arrival(std::uint32_t seen) const {
    arrivals_.wait(seen, std::memory_order_acquire);
  }
  /// Wakes a consumer asleep in wait_for_arrival() (pushes do this; also for shutdown).
  /// Never blocks.
  void wake() {
    arrivals_.fetch_add(1, std::memory_order_release);
    arrivals_.notify_one();
  }

 private:
  SpscRing<engine::SurfaceChange, kCapacity> queue_;
  // Producer-only state.
  bool pending_valid_ = false;
  engine::SurfaceChange pending_;
  std::atomic<std::uint64_t> overflows_{0};
  std::atomic<std::uint32_t> arrivals_{0};
};

}  // namespace hapvox::haptics
