#pragma once
// A wait-free hand-off of the latest value from one thread to another: the FEM's snapshots to
// the force thread (haptics/fem_model.h), its node displacements to the render thread
// (haptics/render_feed.h).

#include <array>
#include <atomic>
#include <cstdint>

namespace hapvox::haptics {

/// A wait-free single-producer single-consumer triple buffer.
template <class T>
class TripleBuffer {
 public:
  /// Producer: the slot to fill before publish().
  T& write_slot() { return slots_[write_]; }
  /// Producer: makes the write slot the latest.
  void publish() noexcept {
    write_ =
        latest_.exchange(static_cast<std::uint8_t>(write_ | kFresh), std::memory_order_acq_rel) &
        kIndex;
  }
  /// Consumer: the latest published value (the one read before, when nothing is new).
  const T& read() noexcept {
    if (latest_.load(std::memory_order_acquire) & kFresh) {
      read_ = latest_.exchange(read_, std::memory_order_acq_rel) & kIndex;
    }
    return slots_[read_];
  }

 private:
  static constexpr std::uint8_t kFresh = 4;
  static constexpr std::uint8_t kIndex = 3;
  std::array<T, 3> slots_{};
  std::atomic<std::uint8_t> latest_{0};
  std::uint8_t write_ = 1;  // producer only
  std::uint8_t read_ = 2;   // consumer only
};

}  // namespace hapvox::haptics
