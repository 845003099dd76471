#pragma once
// Volume shadows (Nakao §4.1, after Behrens & Ratering): how much of a light above the volume
// (shining down its -z axis, the volume's "up" being +z) reaches each voxel, through the
// material above it, as a second 3D texture the slice shader multiplies its shading by.
//
//   T(x, y, z) = prod_{z' > z} (1 - a(z'))
//
// with a the transfer function's opacity of the voxel's density (per voxel of path, as the
// renderer's): the light reaching the voxel's top, so a surface facing the light is fully
// lit (counting the voxel's own half path too darkened every lit surface). Soft attenuation: T is
// averaged over a (2b + 1)^2 box of columns in x and y (b = blur_voxels), a penumbra b voxels
// wide at every shadow's edge. Work is by brick column (8 x 8 voxels, all of z): a changed
// brick marks its column and the columns within the blur, which alone are recomputed, so a
// deformation's shadows move with it at the cost of the columns it touched.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace hapvox::render {

class ShadowVolume {
 public:
  /// All columns marked: the first update computes the whole volume.
  ShadowVolume(const Eigen::Vector3i& dims, int blur_voxels);

  /// Marks the columns of these bricks (indices x fastest over brick_counts(dims)).
  void mark_bricks(const std::vector<std::uint32_t>& bricks);
  void mark_all();

  /// Recomputes the marked columns from `texels` (RGBA8, render/texels.h: A is the density
  /// byte) and `opacity` (the transfer function's opacity at density i / 255). Returns the
  /// bricks whose transmittance was recomputed (to upload), x fastest, ascending.
  const std::vector<std::uint32_t>& update(const std::vector<std::uint8_t>& texels,
                                           const std::array<float, 256>& opacity);

  /// Transmittance, one byte a voxel (255: fully lit), the texels' layout.
  const std::vector<std::uint8_t>& transmittance() const { return transmittance_; }
  double at(int x, int y, int z) const {
    return transmittance_[(static_cast<std::size_t>(z) * dims_.y() + y) * dims_.x() + x] / 255.0;
  }
  const Eigen::Vector3i& dims() const { return dims_; }
  int blur_voxels() const { return blur_; }

 private:
  // `pass`: 1 - a, the light a voxel of each density byte lets through.
  void compute_column(int bx, int by, const std::vector<std::uint8_t>& texels,
                      const std::array<float, 256>& pass);

  Eigen::Vector3i dims_;
  Eigen::Vector3i bricks_;
  int blur_;
  std::vector<std::uint8_t> transmittance_;
  std::vector<std::uint8_t> column_marked_;  // per brick column (bx, by)
  std::vector<std::uint32_t> changed_;
  std::vector<float> raw_, across_x_;  // scratch: unblurred T, then blurred along x
};

}  // namespace hapvox::render
