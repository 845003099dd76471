#pragma once
// A bounded single-producer, single-consumer ring in which neither side ever waits for the
// other: try_push() fails when the ring is full, try_pop() when it is empty, and each is a
// few loads and one release store. No allocation (the slots are inline), no locks.
//
// Why not atomic_queue (which hapvox used here before): its push and pop claim a slot by
// moving the head or tail index first and then spin on that slot's state until the other
// side has finished with it. A consumer preempted between the two steps of a pop leaves the
// producer spinning; when the producer is SCHED_FIFO on the consumer's CPU the consumer
// cannot run again until the kernel lends ordinary threads time (its fair server: 50 ms in
// every second), so the producer stalled for a second. Seen: the paced relaxation thread
// (SCHED_FIFO) pushing changed voxels to the render thread (SCHED_OTHER) on the same CPU
// stopped the force loop for 1.0 and 2.0 s. Here an index moves only after its slot is
// done with, so a preempted side only delays what the other sees, never stops it.

#include <array>
#include <atomic>
#include <cstddef>

namespace hapvox::haptics {

template <class T, std::size_t Capacity>
class SpscRing {
  static_assert(Capacity > 0 && (Capacity & (Capacity - 1)) == 0, "a power of two");

 public:
  static constexpr std::size_t kCapacity = Capacity;

  /// Producer. False (and nothing stored) when the ring is full.
  bool try_push(const T& value) noexcept {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_.load(std::memory_order_acquire) == Capacity) return false;
    slots_[head & (Capacity - 1)] = value;
    head_.store(head + 1, std::memory_order_release);  // the slot is written
    return true;
  }
  /// Consumer. False when the ring is empty.
  bool try_pop(T& value) noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    value = slots_[tail & (Capacity - 1)];
    tail_.store(tail + 1, std::memory_order_release);  // the slot is read
    return true;
  }
  /// How many values were queued a moment ago (either side; exact on a quiet ring).
  std::size_t was_size() const noexcept {
    const std::size_t tail = tail_.load(std::memory_order_acquire);
    const std::size_t head = head_.load(std::memory_order_acquire);
    return head >= tail ? head - tail : 0;  // the tail read first: a pop in between
  }

 private:
  std::array<T, Capacity> slots_{};
  alignas(64) std::atomic<std::size_t> head_{0};  // written by the producer only
  alignas(64) std::atomic<std::size_t> tail_{0};  // written by the consumer only
};

}  // namespace hapvox::haptics
