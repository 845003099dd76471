#include "haptics/sweep_merger.h"

#include <algorithm>

namespace hapvox::haptics {
namespace {

// Distance from p to the segment [a, b].
double distance_to_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                           const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double length2 = ab.squaredNorm();
  const double t = length2 > 0.0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

}  // namespace

bool SweepMerger::take(SurfaceChangeChannel& channel, engine::SurfaceChange& change) {
  if (carried_valid_) {
    change = carried_;
    carried_valid_ = false;
    return true;
  }
  return channel.pop(change);
}

// `next` continues the sweep when it has the same radius, starts where the sweep ends (a
// change the channel coalesced starts earlier), and every centre so far, and its own
// start, lies within the tolerance of the segment from the sweep's start to its end.
bool SweepMerger::continues(const engine::SurfaceChange& sweep,
                            const engine::SurfaceChange& next) const {
  if (next.radius_mm != sweep.radius_mm) return false;
  const Eigen::Vector3d& a = sweep.from_mm;
  const Eigen::Vector3d& b = next.position_mm;
  if (distance_to_segment(next.from_mm, a, b) > kStraightToleranceMm) return false;
  for (std::size_t i = 0; i < path_size_; ++i) {
    if (distance_to_segment(path_[i], a, b) > kStraightToleranceMm) return false;
  }
  return true;
}

bool SweepMerger::next_sweep(SurfaceChangeChannel& channel, engine::SurfaceChange& sweep,
                             std::size_t* merged_changes) {
  if (!take(channel, sweep)) return false;
  path_size_ = 0;
  path_[path_size_++] = sweep.position_mm;
  std::size_t changes = 1;
  engine::SurfaceChange next;
  while (changes < kMaxChanges && take(channel, next)) {
    if (!continues(sweep, next)) {
      carried_ = next;
      carried_valid_ = true;
      break;
    }
    sweep.position_mm = next.position_mm;
    sweep.direction = next.direction;
    sweep.event = next.event;
    path_[path_size_++] = next.position_mm;
    ++changes;
  }
  if (merged_changes != nullptr) *merged_changes = changes;
  return true;
}

}  // namespace hapvox::haptics
