#include "engine/leaf_window.h"

#include <cmath>

namespace hapvox::engine {
namespace {

constexpr int kLeafDim = 8;
// Leaves of slack around the tool's reach: the centre moves up to about a leaf (8 voxels)
// before the table is rebuilt.
constexpr int kMarginLeaves = 2;
// Far outside any grid (a trace in the wrong units): the reads are then left to the
// accessor. Below 2^22 a float holds every index with a quarter voxel to spare, so the
// float sums of the reads (a float centre plus float offsets) stay within the voxel of slack
// cover() keeps each way; beyond it they could step past the table.
constexpr double kMaxIndex = 1 << 22;

}  // namespace

void LeafWindow::reserve(const Eigen::Vector3d& reach_index) {
  reach_index_ = reach_index;
  for (int a = 0; a < 3; ++a) {
    // A stencil within reach of the centre (and a voxel more each way, cover) spans at
    // most 2 reach + 4 voxels, and those at most ceil((2 reach + 4) / 8) + 1 leaves.
    const int span_leaves =
        static_cast<int>(std::ceil((2.0 * reach_index[a] + 4.0) / kLeafDim)) + 1;
    dims_[a] = span_leaves + kMarginLeaves;
  }
  entries_.assign(static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2], Entry{});
  valid_ = false;
}

bool LeafWindow::cover(const Eigen::Vector3d& center_index,
                       openvdb::FloatGrid::ConstAccessor& accessor) {
  if (entries_.empty()) return false;
  if (!center_index.allFinite() || center_index.cwiseAbs().maxCoeff() > kMaxIndex) return false;
  int lo[3], hi[3];
  bool inside = valid_;
  for (int a = 0; a < 3; ++a) {
    // A voxel more each way: the reads add float offsets to a float centre, which may
    // round across a voxel face the double sums do not reach.
    lo[a] = static_cast<int>(std::floor(center_index[a] - reach_index_[a])) - 1;
    hi[a] = static_cast<int>(std::floor(center_index[a] + reach_index_[a])) + 2;
    inside = inside && lo[a] >= lo_voxel_[a] && hi[a] <= hi_voxel_[a];
  }
  if (inside) return true;
  openvdb::Coord low_leaf;
  for (int a = 0; a < 3; ++a) {
    // Centre the needed leaves in the table (>> rounds toward minus infinity).
    const int first = lo[a] >> 3, last = hi[a] >> 3;
    low_leaf[a] = first - (dims_[a] - (last - first + 1)) / 2;
  }
  rebuild(low_leaf, accessor);
  return true;
}

void LeafWindow::rebuild(const openvdb::Coord& low_leaf,
                         openvdb::FloatGrid::ConstAccessor& accessor) {
  for (int a = 0; a < 3; ++a) {
    base_[a] = low_leaf[a];
    lo_voxel_[a] = low_leaf[a] * kLeafDim;
    hi_voxel_[a] = (low_leaf[a] + dims_[a]) * kLeafDim - 1;
  }
  std::size_t k = 0;
  for (int x = 0; x < dims_[0]; ++x) {
    for (int y = 0; y < dims_[1]; ++y) {
      for (int z = 0; z < dims_[2]; ++z, ++k) {
        const openvdb::Coord origin((base_[0] + x) * kLeafDim, (base_[1] + y) * kLeafDim,
                                    (base_[2] + z) * kLeafDim);
        Entry& e = entries_[k];
        const openvdb::FloatTree::LeafNodeType* leaf = accessor.probeConstLeaf(origin);
        // No leaf: one tile (of some level) or the background covers the whole 8^3 block.
        e.voxels = leaf != nullptr ? leaf->buffer().data() : nullptr;
        e.tile_value = leaf != nullptr ? 0.0f : accessor.getValue(origin);
      }
    }
  }
  valid_ = true;
  ++rebuilds_;
}

}  // namespace hapvox::engine
