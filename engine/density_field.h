#pragma once
// The density field: a sparse OpenVDB float grid of material density in [0, 1]
// (1 = the material's normal density, 0 = empty) with the index-to-world affine of the
// scan it came from: voxel sizes in millimetres (per axis, spacings may differ), direction
// cosines and an origin. Index (0,0,0) is the centre of the first voxel; the world position
// of index ijk is
//     origin_mm + direction * (ijk * voxel_size_mm)     (per-axis product)
// in the patient frame DICOM and ITK use, LPS: +x towards the patient's left, +y posterior,
// +z superior. Readers of RAS formats (NIfTI) convert at the edge. Column a of `direction`
// is the world direction of index axis a; it is orthonormal (either handedness).
//
// The grid frame is the world turned about the origin so that the index axes lie along x,
// y, z: grid = origin + direction^T (world - origin). Axis-aligned consumers (the
// renderer, the proxy mesh) work there; tool forces are computed and reported in world.
// Empty space is the inactive background value 0.

#include <openvdb/openvdb.h>

#include <Eigen/Core>
#include <string>

namespace hapvox::engine {

using Vec3d = Eigen::Vector3d;
using Vec3i = Eigen::Vector3i;
using Mat3d = Eigen::Matrix3d;

class DensityField {
 public:
  /// Takes ownership of `grid` (background must be 0). `dims` is the index extent the
  /// data came from ([0, dims) per axis); it is metadata, the grid itself is unbounded.
  /// `direction` must be orthonormal (CHECKed; readers refuse others with an InputError).
  DensityField(openvdb::FloatGrid::Ptr grid, const Vec3d& voxel_size_mm, const Vec3d& origin_mm,
               const Vec3i& dims, const Mat3d& direction = Mat3d::Identity());

  const openvdb::FloatGrid& grid() const { return *grid_; }
  openvdb::FloatGrid& mutable_grid() { return *grid_; }
  openvdb::FloatGrid::Ptr grid_ptr() const { return grid_; }

  const Vec3d& voxel_size_mm() const { return voxel_size_mm_; }
  const Vec3d& origin_mm() const { return origin_mm_; }
  const Vec3i& dims() const { return dims_; }
  const Mat3d& direction() const { return direction_; }
  /// True when the index axes are world x, y, z (direction is the identity).
  bool axis_aligned() const { return axis_aligned_; }

  Vec3d index_to_world(const Vec3d& ijk) const {
    return origin_mm_ + direction_ * ijk.cwiseProduct(voxel_size_mm_);
  }
  Vec3d world_to_index(const Vec3d& p_mm) const {
    return (direction_.transpose() * (p_mm - origin_mm_)).cwiseQuotient(voxel_size_mm_);
  }
  /// World <-> grid frame (see the top of this file); both the identity when axis_aligned().
  Vec3d world_to_grid(const Vec3d& p_mm) const {
    return origin_mm_ + direction_.transpose() * (p_mm - origin_mm_);
  }
  Vec3d grid_to_world(const Vec3d& q_mm) const {
    return origin_mm_ + direction_ * (q_mm - origin_mm_);
  }
  /// The grid-frame box covering the voxels [0, dims) (voxel faces, not centres).
  Vec3d grid_min_mm() const { return origin_mm_ - 0.5 * voxel_size_mm_; }
  Vec3d grid_max_mm() const {
    return origin_mm_ + (dims_.cast<double>() - Vec3d::Constant(0.5)).cwiseProduct(voxel_size_mm_);
  }
  /// The world-space bounding box of the voxels [0, dims) (of the box's 8 corners).
  Vec3d world_min_mm() const;
  Vec3d world_max_mm() const;

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
  Mat3d direction_;
  bool axis_aligned_;
};

/// Calls openvdb::initialize() once (thread-safe, idempotent).
void initialize_openvdb();

}  // namespace hapvox::engine
