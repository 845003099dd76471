#pragma once
// The density field: a sparse OpenVDB float grid of material density in [0, 1]
// (1 = the material's normal density, 0 = empty) with a voxel size in millimetres
// and an origin. Index (0,0,0) is the centre of the first voxel; the world position of
// index ijk is origin_mm + ijk * voxel_size_mm (per axis, spacings may differ).
// Empty space is the inactive background value 0.

#include <openvdb/openvdb.h>

#include <Eigen/Core>
#include <string>

namespace hapvox::engine {

using Vec3d = Eigen::Vector3d;
using Vec3i = Eigen::Vector3i;

class DensityField {
 public:
  /// Takes ownership of `grid` (background must be 0). `dims` is the index extent the
  /// data came from ([0, dims) per axis); it is metadata, the grid itself is unbounded.
  DensityField(openvdb::FloatGrid::Ptr grid, const Vec3d& voxel_size_mm, const Vec3d& origin_mm,
               const Vec3i& dims);

  const openvdb::FloatGrid& grid() const { return *grid_; }
  openvdb::FloatGrid& mutable_grid() { return *grid_; }
  openvdb::FloatGrid::Ptr grid_ptr() const { return grid_; }

  const Vec3d& voxel_size_mm() const { return voxel_size_mm_; }
  const Vec3d& origin_mm() const { return origin_mm_; }
  const Vec3i& dims() const { return dims_; }

  Vec3d index_to_world(const Vec3d& ijk) const {
    return origin_mm_ + ijk.cwiseProduct(voxel_size_mm_);
  }
  Vec3d world_to_index(const Vec3d& p_mm) const {
    return (p_mm - origin_mm_).cwiseQuotient(voxel_size_mm_);
  }
  /// World-space box covering the voxels [0, dims) (voxel faces, not centres).
  Vec3d world_min_mm() const { return index_to_world(Vec3d::Constant(-0.5)); }
  Vec3d world_max_mm() const { return index_to_world(dims_.cast<double>() - Vec3d::Constant(0.5)); }

  /// Trilinear density at a world position (slow path: a fresh accessor per call).
  double sample_world(const Vec3d& p_mm) const;
  /// Sum of all voxel densities (double accumulation).
  double total_density() const;
  /// Number of active (non-empty) voxels.
  openvdb::Index64 active_voxel_count() const { return grid_->activeVoxelCount(); }

 private:
  openvdb::FloatGrid::Ptr grid_;
  Vec3d voxel_size_mm_;
  Vec3d origin_mm_;
  Vec3i dims_;
};

/// Calls openvdb::initialize() once (thread-safe, idempotent).
void initialize_openvdb();

}  // namespace hapvox::engine
