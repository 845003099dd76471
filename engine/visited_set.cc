#include "engine/visited_set.h"

#include <algorithm>

namespace hapvox::engine {

void VisitedSet::make_dense(const openvdb::CoordBBox& box) {
  clear();
  box_ = openvdb::CoordBBox();
  bits_.clear();
  if (box.empty() || box.volume() > kMaxDenseVoxels) return;
  box_ = box;
  dim_x_ = static_cast<std::uint64_t>(box.dim().x());
  dim_y_ = static_cast<std::uint64_t>(box.dim().y());
  // Value-initialised: every page is written here, at start, not on a flow's first visit.
  bits_.assign((box.volume() + 63) / 64, 0);
}

bool VisitedSet::contains(const openvdb::Coord& ijk) const {
  if (!box_.isInside(ijk)) return outside_->tree().isValueOn(ijk);
  const std::uint64_t bit = index(ijk);
  return (bits_[bit >> 6] >> (bit & 63)) & 1;
}

bool VisitedSet::insert_outside(const openvdb::Coord& ijk) {
  if (outside_accessor_.isValueOn(ijk)) return false;
  outside_accessor_.setValueOn(ijk);
  outside_used_ = true;
  return true;
}

void VisitedSet::clear() {
  if (!marked_.empty()) {
    // Each row of the marked box: bits first..last of one x run.
    for (int z = marked_.min().z(); z <= marked_.max().z(); ++z) {
      for (int y = marked_.min().y(); y <= marked_.max().y(); ++y) {
        const std::uint64_t first = index(openvdb::Coord(marked_.min().x(), y, z));
        const std::uint64_t last = index(openvdb::Coord(marked_.max().x(), y, z));
        for (std::uint64_t word = first >> 6; word <= last >> 6; ++word) {
          const std::uint64_t lo = word == first >> 6 ? first & 63 : 0;
          const std::uint64_t hi = word == last >> 6 ? last & 63 : 63;
          // Bits lo..hi of the word.
          const std::uint64_t mask = (~std::uint64_t{0} >> (63 - hi)) & (~std::uint64_t{0} << lo);
          bits_[word] &= ~mask;
        }
      }
    }
    marked_ = openvdb::CoordBBox();
  }
  if (outside_used_) {
    outside_->clear();
    outside_accessor_.clear();
    outside_used_ = false;
  }
}

}  // namespace hapvox::engine
