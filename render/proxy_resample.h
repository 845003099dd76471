#pragma once
// The volume as the proxy mesh deforms it, resampled into the renderer's 3D texture brick by
// brick (Nakao et al. 2010, §4.1, the "resample the changed bricks" way of the issue): every
// voxel centre x inside a deformed tet shows the material of its rest point
// X = sum_a lambda_a(x) X_a (lambda the tet's barycentric coordinates at x), sampled
// trilinearly from the rest texels as the GPU would, with the gradient turned by
// render/gradient_rotation.h. Today's renderer then draws the texture unchanged.
//
// Only tets that moved are resampled: a tet moved when one of its vertices did by more than
// `motion_threshold_voxels` (an eighth of a 8-bit level's worth of a sharp edge by default).
// Their rest and deformed boxes mark the bricks that change; every other brick keeps the rest
// texels bit for bit, and a brick that was deformed and is no longer gets them back. A voxel
// of a moved tet's rest place that no deformed tet covers any more is empty (the material
// left it); material moved out of the volume's box is not drawn.
//
// Single-threaded and deterministic: the same displacement gives the same texels.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "engine/fem/tet_mesh.h"
#include "render/gradient_rotation.h"
#include "render/texels.h"

namespace hapvox::render {

struct ResampleOptions {
  GradientTransform gradient = GradientTransform::kVertexRotation;
  double motion_threshold_voxels = 1.0 / 512.0;
};

struct ResampleStats {
  std::size_t moved_tets = 0;
  std::size_t resampled_voxels = 0;  // voxel centres inside a moved, deformed tet
  std::size_t vacated_voxels = 0;    // emptied: a moved tet's rest place no tet covers now
  std::size_t changed_bricks = 0;    // uploaded this update (deformed, or restored)
  double ms = 0.0;
};

class ProxyResampler {
 public:
  /// The rest texels of `rest` (render/texels.h), as the renderer computes them.
  ProxyResampler(const DenseVolume& rest, const ResampleOptions& options = {});

  /// The mesh displacements refer to (world mm, the volume's frame): the run's first, or a
  /// remesh. Bricks the last update deformed stay so until the next update.
  void set_mesh(const engine::fem::TetMesh& mesh);

  /// Resamples for `displacement_mm` (3 per vertex of the mesh). Afterwards texels() is the
  /// deformed volume and changed_bricks() the bricks that differ from the last update's.
  ResampleStats update(const Eigen::Ref<const Eigen::VectorXd>& displacement_mm);

  /// RGBA8 texels of the whole box, the renderer's layout.
  const std::vector<std::uint8_t>& texels() const { return texels_; }
  const std::vector<std::uint8_t>& rest_texels() const { return rest_texels_; }
  /// Brick indices (x fastest over brick_counts(dims)) changed by the last update.
  const std::vector<std::uint32_t>& changed_bricks() const { return changed_; }
  const Eigen::Vector3i& dims() const { return dims_; }

 private:
  // Visits the voxel centres inside the tet with z in [z_from, z_to].
  template <class Visit>
  void rasterize(const Eigen::Matrix<double, 3, 4>& corners_mm, int z_from, int z_to,
                 Visit&& visit) const;
  // The moved tets' voxels with z in [z_from, z_to]: their rest places marked vacated, their
  // deformed places resampled (the first tet in index order keeps a shared voxel).
  std::size_t resample_slab(int z_from, int z_to,
                            const Eigen::Ref<const Eigen::VectorXd>& displacement_mm);
  void mark_bricks(const Eigen::Vector3d& lo_mm, const Eigen::Vector3d& hi_mm);
  std::size_t index(int x, int y, int z) const {
    return (static_cast<std::size_t>(z) * dims_.y() + y) * dims_.x() + x;
  }

  ResampleOptions options_;
  Eigen::Vector3i dims_;
  Eigen::Vector3d voxel_mm_, lo_mm_;
  Eigen::Vector3i bricks_;
  std::vector<std::uint8_t> rest_texels_;
  std::vector<std::uint8_t> texels_;
  engine::fem::TetMesh mesh_;
  std::vector<std::array<std::int32_t, 2>> frame_neighbours_;
  // Per update (kept to reuse their storage):
  std::vector<std::uint8_t> state_;  // per voxel: 0 untouched, 1 vacated, 2 resampled
  std::vector<std::uint8_t> brick_now_, brick_before_;
  std::vector<std::uint32_t> bricks_now_, bricks_before_, changed_;
  std::vector<Eigen::Matrix3d> vertex_rotations_;
  std::vector<std::uint8_t> vertex_moved_, vertex_rotated_;
  std::vector<std::int32_t> moved_tets_;
  std::vector<Eigen::Matrix3d> tet_inverse_transposes_;  // per moved tet, with kTetInverseTranspose
};

}  // namespace hapvox::render
