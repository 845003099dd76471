#pragma once
// The FFD slice mesh (Prados et al., interactive elastic deformation, section 5): the
// volume is drawn as view-aligned slices (built farthest first; the renderer draws them
// front to back, render/front_to_back.h); each slice is split into
// patches whose vertices are moved by the tool's current elastic displacement, while each
// vertex keeps the texture coordinate of its undeformed position. Moving a vertex from P
// to P + w(P) u therefore shows the material of P at its displaced place (Eq. 9-10).
//
// Displacement u = x_n - x_0 (tool centre minus contact origin, the force model's
// displacement). Weight w by the distance d = max(0, |P - x_n| - r) from the tool's
// surface (r the tool radius):
//   paper    w = 1 / max(1, d / l)       Eq. 10 (1 inside the tool; l = one voxel)
//   wendland w = (1 - d/R)^4 (4 d/R + 1) for d < R, 0 beyond (C2, compact support R)
// docs/render.md has the derivation and why the compact kernel is the default.
//
// Tessellation:
//   uniform   every slice is a patches x patches grid over its polygon's bounding
//             rectangle (the paper's 500 slices x 20 x 20 patches is the naive baseline);
//   adaptive  slices the kernel cannot reach are a single polygon (no displacement, no
//             wasted fill); the others a tensor grid that is fine (fine_spacing_mm)
//             only across the kernel's support and one cell elsewhere. With a compact
//             kernel the coarse vertices have w = 0 exactly, so both give the same image.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace hapvox::render {

enum class FfdKernel { kPaper, kWendland };
enum class Tessellation { kUniform, kAdaptive };

/// The elastic state the mesh follows: where the tool is and how far it has pushed.
struct ToolPose {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();        // x_n
  Eigen::Vector3d displacement_mm = Eigen::Vector3d::Zero();  // u = x_n - x_0 (zero: none)
  double radius_mm = 0.0;                                     // 0: no tool
  bool in_contact = false;
};

struct SliceMeshOptions {
  int slices = 256;
  Tessellation tessellation = Tessellation::kAdaptive;
  int patches = 20;  // per side, kUniform
  FfdKernel kernel = FfdKernel::kWendland;
  double support_mm = 0.0;       // R of the Wendland kernel; 0: 3 x the tool radius
  double fine_spacing_mm = 0.0;  // kAdaptive cell size near the tool; 0: R / 8
  /// kAdaptive, > 0: cells may grow past R / 8 (to at most R / 2) while the mesh's linear
  /// interpolation of the displacement stays within this many mm of the kernel's:
  /// |w u - I(w u)| <= 5 (h / R)^2 |u| (a triangle of legs h: h^2 / 4 times the largest
  /// second derivative of the Wendland weight, 20 / R^2). The renderer passes half a pixel.
  double max_error_mm = 0.0;
  double voxel_mm = 1.0;  // l of the paper's kernel
};

/// Displacement weight w at distance d_mm from the tool's surface.
double ffd_weight(double d_mm, const SliceMeshOptions& options, double support_mm);

/// dw/dd, the weight's derivative by the distance from the tool's surface (1/mm).
double ffd_weight_slope(double d_mm, const SliceMeshOptions& options, double support_mm);

/// Displaced position of P (the mesh's deformation function f of Eq. 9).
Eigen::Vector3d ffd_displace(const Eigen::Vector3d& p_mm, const ToolPose& tool,
                             const SliceMeshOptions& options);

/// Gradient of the weight at P, grad w (1/mm). The deformation's Jacobian is
/// J = I + u grad w^T, so a normal n becomes J^-T n = n - grad w (u.n) / (1 + grad w.u)
/// (Sherman-Morrison): shading follows the press (the role of Nakao's rotated gradients).
Eigen::Vector3d ffd_weight_gradient(const Eigen::Vector3d& p_mm, const ToolPose& tool,
                                    const SliceMeshOptions& options);

/// Interleaved vertex: displaced position (mm), undeformed position (mm; the shader turns
/// it into texture coordinates) and the weight gradient there (1/mm).
struct SliceVertex {
  float position[3];
  float rest[3];
  float weight_gradient[3];
};

struct SliceMesh {
  std::vector<SliceVertex> vertices;
  std::vector<std::uint32_t> indices;  // triangles, slices in back-to-front order
  /// Where each slice's triangles start in `indices`, one entry per slice and the end
  /// (`indices.size()`) last: what front-to-back drawing reorders (render/front_to_back.h).
  std::vector<std::uint32_t> slice_first_index;
  int slices = 0;
  double slice_spacing_mm = 0.0;
};

/// The corners of plane {x : n.x = s} cut by the box [lo, hi], in order around the
/// polygon (empty when the plane misses the box).
std::vector<Eigen::Vector3d> slice_polygon(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                                           const Eigen::Vector3d& n, double s);

/// Builds slices perpendicular to `view_direction` (unit, pointing away from the eye),
/// farthest first, deformed by `tool`, reusing `mesh`'s storage. The planes lie on a
/// lattice of options.slices planes across the box [frame_lo, frame_hi] (the volume), so
/// they never move with the tool or the material; only those that cut [lo, hi] (the part
/// with visible material) are built, cut to that box.
void build_slice_mesh(const Eigen::Vector3d& frame_lo, const Eigen::Vector3d& frame_hi,
                      const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                      const Eigen::Vector3d& view_direction, const ToolPose& tool,
                      const SliceMeshOptions& options, SliceMesh& mesh);

}  // namespace hapvox::render
