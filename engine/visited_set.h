#pragma once
// VisitedSet: the voxels a breadth-first search has reached, for MassGrid's flow to room.
//
// A bit a voxel over a dense box fixed at construction (the volume's index box and a
// margin), allocated and touched there, and a sparse mask for anything outside it (clay
// the flow pushed past the volume's edge). Forgetting every mark clears only the rows of
// the box the marks reached. It replaces an OpenVDB mask grid that was cleared, and its
// leaves freed, after every flow: each visit paid for a tree walk, and each flow for new
// leaves' page faults and a parallel clear (issue 29, point 3; docs/performance.md).

#include <openvdb/openvdb.h>

#include <cstdint>
#include <vector>

namespace hapvox::engine {

class VisitedSet {
 public:
  /// Boxes of more voxels than this are not made dense (the sparse mask serves alone).
  static constexpr std::uint64_t kMaxDenseVoxels = std::uint64_t{1} << 31;

  VisitedSet() = default;
  /// Dense over `box` (inclusive) when it holds at most kMaxDenseVoxels voxels.
  explicit VisitedSet(const openvdb::CoordBBox& box) { make_dense(box); }
  // The sparse part's accessor is bound to its own tree: not copied or moved.
  VisitedSet(const VisitedSet&) = delete;
  VisitedSet& operator=(const VisitedSet&) = delete;

  /// Forgets every mark and makes the set dense over `box` (as the constructor).
  void make_dense(const openvdb::CoordBBox& box);

  /// Marks the voxel; true if it was not marked before.
  bool insert(const openvdb::Coord& ijk) {
    if (!box_.isInside(ijk)) return insert_outside(ijk);
    const std::uint64_t bit = index(ijk);
    std::uint64_t& word = bits_[bit >> 6];
    const std::uint64_t mask = std::uint64_t{1} << (bit & 63);
    if (word & mask) return false;
    word |= mask;
    marked_.expand(ijk);
    return true;
  }
  bool contains(const openvdb::Coord& ijk) const;
  /// Forgets every mark.
  void clear();
  bool dense() const { return !bits_.empty(); }

 private:
  std::uint64_t index(const openvdb::Coord& ijk) const {
    return (static_cast<std::uint64_t>(ijk.z() - box_.min().z()) * dim_y_ +
            static_cast<std::uint64_t>(ijk.y() - box_.min().y())) *
               dim_x_ +
           static_cast<std::uint64_t>(ijk.x() - box_.min().x());
  }
  bool insert_outside(const openvdb::Coord& ijk);

  openvdb::CoordBBox box_;  // empty (inverted) when there are no dense bits
  std::uint64_t dim_x_ = 0, dim_y_ = 0;
  std::vector<std::uint64_t> bits_;
  openvdb::CoordBBox marked_;  // the box of the dense marks since the last clear
  openvdb::MaskGrid::Ptr outside_ = openvdb::MaskGrid::create(false);
  openvdb::MaskGrid::Accessor outside_accessor_ = outside_->getAccessor();
  bool outside_used_ = false;
};

}  // namespace hapvox::engine
