#pragma once
// The proxy mesh's deformation drawn the paper's way (Nakao et al. 2010, §4.1): view-aligned
// slices of the deformed tet mesh, each vertex carrying its rest position as the 3D-texture
// coordinate, as a block hybrid: the volume's box is cut into blocks of `block_voxels`^3; a
// block is deformed when a moved tet's rest or deformed box reaches it. Slices through the
// other blocks are today's plain polygons (the block's box cut by the plane, texture
// coordinate = position); in deformed blocks every tet that reaches them is cut by the plane
// at its deformed place and the piece clipped to the block. The texture keeps the rest
// texels. The alternative to render/proxy_resample.h that the issue asks to measure against
// it (`hapvox bench render`'s "block hybrid" rows; docs/performance.md has the numbers).
//
// Shading: the slice vertices carry no rotation, so the gradient is the rest one (neither R
// nor F^-T); the comparison is of speed and of the material's place.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "engine/fem/tet_mesh.h"
#include "render/slice_mesh.h"

namespace hapvox::render {

struct TetSliceStats {
  std::size_t moved_tets = 0;
  std::size_t deformed_blocks = 0;
  std::size_t sliced_tets = 0;  // tets cut by the planes (those reaching deformed blocks)
};

class TetSlicer {
 public:
  /// The volume's box [frame_lo, frame_hi] (mm) of `dims` voxels, cut into blocks of
  /// `block_voxels`^3.
  TetSlicer(const Eigen::Vector3d& frame_lo, const Eigen::Vector3d& frame_hi,
            const Eigen::Vector3i& dims, int block_voxels = 32);

  /// The mesh displacements refer to; it must outlive the slicer (kept by reference).
  void set_mesh(const engine::fem::TetMesh& mesh);
  /// Finds the moved tets (a vertex moved by more than `threshold_mm`) and the deformed blocks.
  TetSliceStats set_displacement(const Eigen::Ref<const Eigen::VectorXd>& displacement_mm,
                                 double threshold_mm);

  /// The slices perpendicular to `view_direction`, farthest first, on build_slice_mesh's
  /// lattice of `slices` planes across the frame; plain polygons cut to [lo, hi] (the visible
  /// material). Reuses `mesh`'s storage.
  void build(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
             const Eigen::Vector3d& view_direction, int slices, SliceMesh& mesh) const;

 private:
  Eigen::Vector3d frame_lo_, frame_hi_, block_mm_;
  Eigen::Vector3i blocks_;
  const engine::fem::TetMesh* mesh_ = nullptr;
  Eigen::Matrix3Xd deformed_mm_;
  std::vector<std::uint8_t> block_deformed_;
  std::vector<std::int32_t> sliced_tets_;
};

}  // namespace hapvox::render
