#pragma once
// The renderer's 3D texture, voxel by voxel: a dense copy of a density field and its texels
// (RGBA8: the density gradient's direction in RGB, the density in A), kept in 8^3 bricks, the
// unit a changed region is recomputed and uploaded in. The renderer (render/volume_renderer.h)
// and the proxy-mesh resampler (render/proxy_resample.h) share it, so an undeformed resample
// writes the renderer's own texels, bit for bit.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "engine/density_field.h"

namespace hapvox::render {

/// Edge of a brick, in voxels.
inline constexpr int kBrickVoxels = 8;

/// A dense copy of a density field's index box [0, dims): x fastest, densities in [0, 1].
struct DenseVolume {
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();
  Eigen::Vector3d voxel_mm = Eigen::Vector3d::Ones();
  Eigen::Vector3d lo_mm = Eigen::Vector3d::Zero();  // the box's corner (voxel 0's, not its centre)
  Eigen::Vector3d hi_mm = Eigen::Vector3d::Zero();
  std::vector<float> density;

  std::size_t index(int x, int y, int z) const {
    return (static_cast<std::size_t>(z) * dims.y() + y) * dims.x() + x;
  }
  std::size_t voxel_count() const { return static_cast<std::size_t>(dims.prod()); }
  /// The density at (x, y, z) clamped into the box (the texture's clamp-to-edge).
  float at_clamped(int x, int y, int z) const;
  /// Voxel (x, y, z)'s centre (world mm).
  Eigen::Vector3d centre_mm(int x, int y, int z) const {
    return lo_mm + (Eigen::Vector3d(x, y, z).array() + 0.5).matrix().cwiseProduct(voxel_mm);
  }
};

/// The active voxels of `field` inside [0, dims), densities clamped to [0, 1].
DenseVolume dense_copy(const engine::DensityField& field);

/// The density's gradient at voxel (x, y, z), 1/mm: central differences in world units (the
/// spacings may differ per axis), the neighbours clamped at the box's faces.
Eigen::Vector3d central_gradient(const DenseVolume& volume, int x, int y, int z);

/// One texel: the gradient's direction, each component c stored as round((c + 1) / 2 * 255)
/// (128, 128, 128, unshaded, when |gradient| <= 1e-6), and the density round(rho * 255).
void encode_texel(const Eigen::Vector3d& gradient, float density, std::uint8_t* rgba);

/// Bricks per axis of a box of `dims` voxels (the last one may be partial).
inline Eigen::Vector3i brick_counts(const Eigen::Vector3i& dims) {
  return (dims.array() + kBrickVoxels - 1) / kBrickVoxels;
}

/// The voxel box [lo, hi) of brick `brick` (index x fastest over brick_counts(dims)).
inline void brick_voxel_box(const Eigen::Vector3i& dims, std::uint32_t brick, Eigen::Vector3i& lo,
                            Eigen::Vector3i& hi) {
  const Eigen::Vector3i bricks = brick_counts(dims);
  lo = Eigen::Vector3i(static_cast<int>(brick % bricks.x()),
                       static_cast<int>(brick / bricks.x() % bricks.y()),
                       static_cast<int>(brick / (bricks.x() * bricks.y()))) *
       kBrickVoxels;
  hi = (lo.array() + kBrickVoxels).min(dims.array());
}

}  // namespace hapvox::render
