#include "haptics/surface_channel.h"

#include <algorithm>

namespace hapvox::haptics {

bool SurfaceChangeChannel::flush() {
  if (!pending_valid_) return true;
  if (!queue_.try_push(pending_)) return false;
  pending_valid_ = false;
  wake();
  return true;
}

bool SurfaceChangeChannel::push(const engine::SurfaceChange& change) {
  if (flush() && queue_.try_push(change)) {
    wake();
    return true;
  }
  overflows_.fetch_add(1, std::memory_order_relaxed);
  if (!pending_valid_) {
    pending_ = change;
    pending_valid_ = true;
  } else {
    // Extend the sweep: from the oldest pending start to the newest position.
    pending_.position_mm = change.position_mm;
    pending_.direction = change.direction;
    pending_.radius_mm = std::max(pending_.radius_mm, change.radius_mm);
    pending_.event = change.event;  // its deletion covers every event merged into it
  }
  return false;
}

}  // namespace hapvox::haptics
