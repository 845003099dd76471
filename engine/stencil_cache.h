#pragma once
// The tool's quadrature stencils, kept between ticks (issue 29, point 2;
// docs/performance.md).
//
// The force thread reads the density at the same few thousand points on the tool's
// surface every tick, and the tool moves about 10 um a tick: from one tick to the next
// nearly every point's 2x2x2 trilinear stencil is the same eight voxels. The cache keeps,
// per quadrature point, the voxel its stencil starts at and its eight values, in arrays
// (one per corner) read in the points' order. A tick runs three passes: locate every
// point's stencil (vectorised), re-read through the LeafWindow only the stencils whose
// first voxel changed, and interpolate every point from the arrays (vectorised). The
// interpolation is the accessor path's, term by term, on the same values, and the
// vector instructions round as the scalar ones (no fused multiply-add): the densities are
// bit-identical to reading the grid.
//
// Any change to the grid the values came from must be followed by invalidate() (the
// force state does it with the rest of its caches: ToolForceState::invalidate_cache and
// read_from).

#include <Eigen/Core>
#include <climits>
#include <cstdint>
#include <vector>

#include "engine/leaf_window.h"

namespace hapvox::engine {

class StencilCache {
 public:
  /// Storage for the quadrature points at `offsets` (index space, from the tool's centre).
  /// Allocates: call before the loop.
  void reserve(const std::vector<Eigen::Vector3f>& offsets);
  /// Every stencil is stale (the grid changed, or another grid is read).
  void invalidate();

  /// The trilinear densities at centre + offsets[k] (index space), k in the order of
  /// reserve's offsets; valid until the next call. Every stencil must lie in `window`.
  const float* sample(const Eigen::Vector3f& center_index, const LeafWindow& window);

  /// The arrays hold whole blocks of this many points.
  static constexpr std::size_t kBlock = 8;

  /// Stencils read from the window since reserve (for benchmarks and tests).
  std::uint64_t refills() const { return refills_; }

 private:
  static constexpr int kStale = INT_MIN;
  std::size_t points_ = 0;
  std::vector<float> offset_[3];     // the points' offsets, by axis
  std::vector<int> first_voxel_[3];  // the stencil's (0,0,0) corner by axis; x kStale: none
  std::vector<float> fraction_[3];   // this tick's position inside the stencil, by axis
  std::vector<float> corner_[8];     // v000, v001, v010, v011, v100, v101, v110, v111
  std::vector<int> moved_;           // this tick's stencil differs from the cached one
  std::vector<float> densities_;     // this tick's densities
  std::uint64_t refills_ = 0;
};

}  // namespace hapvox::engine
