#pragma once
// The hand-off from a plastic force tick to the relaxation: what the surface must become.
// Its own header so that the channel (haptics/surface_channel.h), the relaxation
// (engine/relax.h) and the force model include only this, not each other.

#include <cstdint>

#include <Eigen/Core>

namespace hapvox::engine {

/// What a plastic step asks the relaxation to do: empty the tool's sphere at
/// `position_mm` (the tool centre on the new surface), pushing material along `direction`.
/// Coalesced changes sweep the sphere from `from_mm` to `position_mm` (a capsule); a
/// single change has from_mm == position_mm.
struct SurfaceChange {
  Eigen::Vector3d from_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();  // unit
  double radius_mm = 0.0;
  /// The force stage's number for the plastic event that emitted it, counted from 0 in a
  /// run (coalesced changes carry the newest): what the field the force stage reads has
  /// taken in so far is told by this number (TickRecord::published_event). -1: unnumbered.
  std::int64_t event = -1;
};

}  // namespace hapvox::engine
