#pragma once
// A tool-local window onto a density grid's leaves, for the force path's trilinear reads
// (issue 29, point 2; docs/performance.md).
//
// The tool's surface quadrature reads a few thousand points a tick, a third of them with
// a 2x2x2 stencil that straddles two to eight leaves. Through a ValueAccessor each corner
// of such a stencil is a cached tree walk (a node-cache compare, then a descent on a
// miss). The window instead keeps, for every 8^3 leaf of a box around the tool, the
// leaf's voxel buffer (or, where the tree has no leaf, the value of the tile or
// background that stands for it) in a dense table: a read is a table index and the eight
// loads, whichever leaves its corners fall in.
//
// The table is built on the force thread from the thread's own accessor, into storage
// sized before the loop (reserve), whenever the tool leaves it or the grid it reads
// changes (invalidate). It reads the very values the accessor would, so the interpolated
// density is bit-identical to the accessor's.

#include <openvdb/openvdb.h>

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <vector>

#include "engine/trilinear.h"

namespace hapvox::engine {

class LeafWindow {
 public:
  /// Sizes the table for reads within `reach_index` (per axis, index units) of a centre,
  /// with a margin the centre may move through before a rebuild. Allocates: call before
  /// the loop.
  void reserve(const Eigen::Vector3d& reach_index);

  /// The window no longer matches the grid (its leaves changed, or another grid is read).
  void invalidate() { valid_ = false; }

  /// Makes the window cover every trilinear stencil within reserve()'s reach of `center`
  /// (index space), rebuilding it from `accessor` if it does not. False when the window was
  /// never reserved or the centre is too far out for index arithmetic (callers then read
  /// through the accessor).
  bool cover(const Eigen::Vector3d& center_index, openvdb::FloatGrid::ConstAccessor& accessor);

  /// True when the stencil of point `q` (index space) lies in the window.
  bool contains(const Eigen::Vector3f& q) const {
    // floor(q) >= lo and floor(q) + 1 <= hi; false for NaN.
    return valid_ && q.x() >= float(lo_voxel_[0]) && q.x() < float(hi_voxel_[0]) &&
           q.y() >= float(lo_voxel_[1]) && q.y() < float(hi_voxel_[1]) &&
           q.z() >= float(lo_voxel_[2]) && q.z() < float(hi_voxel_[2]);
  }

  /// The trilinear density at `q` (index space); its stencil must lie in the window.
  inline float sample(const Eigen::Vector3f& q) const;

  /// The eight values of the 2x2x2 stencil whose first corner is voxel (ix, iy, iz), in
  /// the order v000, v001, v010, v011, v100, v101, v110, v111 (x slowest); the stencil
  /// must lie in the window.
  inline void stencil(int ix, int iy, int iz, float* v) const;

  /// How many times the table was built (for benchmarks and tests).
  std::uint64_t rebuilds() const { return rebuilds_; }

 private:
  struct Entry {
    const float* voxels = nullptr;  // the leaf's buffer, or nullptr: tile_value throughout
    float tile_value = 0.0f;
  };
  void rebuild(const openvdb::Coord& low_leaf, openvdb::FloatGrid::ConstAccessor& accessor);
  const Entry& entry(int ix, int iy, int iz) const {
    return entries_[static_cast<std::size_t>(
        (((ix >> 3) - base_[0]) * dims_[1] + ((iy >> 3) - base_[1])) * dims_[2] +
        ((iz >> 3) - base_[2]))];
  }
  float voxel(int ix, int iy, int iz) const {
    const Entry& e = entry(ix, iy, iz);
    return e.voxels != nullptr ? e.voxels[((ix & 7) << 6) | ((iy & 7) << 3) | (iz & 7)]
                               : e.tile_value;
  }

  std::vector<Entry> entries_;
  Eigen::Vector3d reach_index_ = Eigen::Vector3d::Zero();
  int dims_[3] = {0, 0, 0};      // leaves per axis
  int base_[3] = {0, 0, 0};      // the first leaf's coordinate (voxel index >> 3) per axis
  int lo_voxel_[3] = {0, 0, 0};  // voxels [lo, hi] per axis lie in the window
  int hi_voxel_[3] = {-1, -1, -1};
  bool valid_ = false;
  std::uint64_t rebuilds_ = 0;
};

inline void LeafWindow::stencil(int ix, int iy, int iz, float* v) const {
  const int lx = ix & 7;
  const int ly = iy & 7;
  const int lz = iz & 7;
  if (lx < 7 && ly < 7 && lz < 7) {
    const Entry& e = entry(ix, iy, iz);
    if (e.voxels == nullptr) {
      for (int k = 0; k < 8; ++k) v[k] = e.tile_value;
      return;
    }
    const float* p = e.voxels + ((lx << 6) | (ly << 3) | lz);
    v[0] = p[0];
    v[1] = p[1];
    v[2] = p[8];
    v[3] = p[9];
    v[4] = p[64];
    v[5] = p[65];
    v[6] = p[72];
    v[7] = p[73];
    return;
  }
  v[0] = voxel(ix, iy, iz);
  v[1] = voxel(ix, iy, iz + 1);
  v[2] = voxel(ix, iy + 1, iz);
  v[3] = voxel(ix, iy + 1, iz + 1);
  v[4] = voxel(ix + 1, iy, iz);
  v[5] = voxel(ix + 1, iy, iz + 1);
  v[6] = voxel(ix + 1, iy + 1, iz);
  v[7] = voxel(ix + 1, iy + 1, iz + 1);
}

inline float LeafWindow::sample(const Eigen::Vector3f& q) const {
  const StencilPoint p = locate_stencil(q);
  float v[8];
  stencil(p.ix, p.iy, p.iz, v);
  return trilinear(v, p.fx, p.fy, p.fz);
}

}  // namespace hapvox::engine
