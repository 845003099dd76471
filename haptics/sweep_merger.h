#pragma once
// The relaxation thread's side of the surface-change hand-off in realtime: the changes
// queued while it was busy come out as few sweeps. A tool ploughing at 20 mm/s emits a
// change a tick, each its sphere 0.02 mm on; a run of them along a straight stretch is
// one capsule from the first centre to the last (the union of the spheres between, to
// within the tolerance), and one deletion of that capsule costs about what one sphere's
// does: the thin shell it adds and its rim. The channel itself coalesces this way when it
// overflows (haptics/surface_channel.h); here it is done before, so that a 64 mm tool's
// deletions keep up with the force loop.
//
// A change that does not continue the sweep (another radius, a bend beyond the tolerance)
// is carried over and starts the next one; nothing is dropped or reordered. Lockstep never
// merges: its replay is the same bit for bit.

#include <array>
#include <cstddef>

#include "engine/surface_change.h"
#include "haptics/surface_channel.h"

namespace hapvox::haptics {

class SweepMerger {
 public:
  /// Most changes one sweep takes in.
  static constexpr std::size_t kMaxChanges = 32;
  /// How far (mm) a merged change's centre may lie from the sweep's segment: a voxel's
  /// coverage ramp moves by at most that (1 % of a 1 mm voxel).
  static constexpr double kStraightToleranceMm = 0.01;

  /// The next sweep: the carried change or the next queued one, extended by the queued
  /// changes that continue it along a straight stretch (at most kMaxChanges in all). It
  /// carries the newest change's position, direction and event. False when none is left.
  /// Consumer thread; no allocation.
  bool next_sweep(SurfaceChangeChannel& channel, engine::SurfaceChange& sweep,
                  std::size_t* merged_changes = nullptr);

  /// A change taken from the channel and not yet given out.
  bool has_carried() const { return carried_valid_; }

 private:
  bool take(SurfaceChangeChannel& channel, engine::SurfaceChange& change);
  bool continues(const engine::SurfaceChange& sweep, const engine::SurfaceChange& next) const;

  bool carried_valid_ = false;
  engine::SurfaceChange carried_;
  // The centres the sweep so far passes through (its start, and each change's end).
  std::array<Eigen::Vector3d, kMaxChanges + 1> path_{};
  std::size_t path_size_ = 0;
};

}  // namespace hapvox::haptics
