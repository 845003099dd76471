#pragma once
// Picking on the rendered volume (Nakao §3.2): the point a pixel's ray first meets the
// surface, on the render thread's own copy of the density (render/texels.h), so picking
// reads no tree another thread writes. The surface is where the trilinearly interpolated
// density (the renderer's texture filter) reaches a threshold.

#include <Eigen/Core>
#include <optional>

#include "render/texels.h"

namespace hapvox::render {

/// The trilinear density at `p_mm` (the volume's frame), voxel centres at their values and
/// the faces clamped, as the renderer's texture samples it.
double density_at(const DenseVolume& volume, const Eigen::Vector3d& p_mm);

/// The first point of the ray origin + t direction (t >= 0) inside the volume's box where
/// the density reaches `threshold`; nullopt when the ray misses the box or never reaches it.
/// Marched in quarter-voxel steps, then bisected to 1e-6 of a voxel.
std::optional<Eigen::Vector3d> pick_surface(const DenseVolume& volume,
                                            const Eigen::Vector3d& origin_mm,
                                            const Eigen::Vector3d& direction, double threshold);

/// The surface's outward normal at `p_mm`: minus the trilinear density's gradient (central
/// differences half a voxel either side), normalised; zero where the density is flat.
Eigen::Vector3d surface_normal(const DenseVolume& volume, const Eigen::Vector3d& p_mm);

/// Where a sphere tool hovers clear of the surface: the first point start + t direction
/// (t >= 0, in quarter-voxel steps, at most `max_distance_mm`) where the density is below
/// `threshold` at the centre and at 26 points of the sphere of `radius_mm` around it (the
/// cube's face, edge and corner directions). The farthest point tried when none is clear.
/// A hover beside a groove narrower than the tool would touch the groove's other wall if
/// it stood off along the normal of the wall under the cursor.
Eigen::Vector3d clear_of_material(const DenseVolume& volume, const Eigen::Vector3d& start_mm,
                                  const Eigen::Vector3d& direction, double radius_mm,
                                  double threshold, double max_distance_mm);

}  // namespace hapvox::render
