// Where the material's nominal surface lies below the tool's pole, to a fraction of a
// voxel (tool_force.h; docs/physics.md, "Sub-voxel contact").
//
// A voxel edge is a density ramp about a voxel wide (trilinear reads of a full/empty
// edge; wider where a scan's voxels hold partial volumes). The surface quadrature sees
// the ramp: S = sum rho dA counts the ramp's outer half too, so a pole within the ramp
// reads a cap too large (at a quarter voxel deep, S is 12 % above 2 pi R d on a
// full/empty face), and the first sample to reach density 1/2 is rarely the pole (the
// onset comes late by R (1 - cos theta) of the nearest sample's angle).
//
// Along a line through the pole p = x + R n, the density tells both: integrated from
// outside the ramp to past it, it puts the surface where the material it holds would
// begin if it were solid (the mass-consistent surface: exact for a flat ramp of any shape,
// a full/empty or a partial-volume edge), and integrated up to the pole it is the depth
// S's cap stands for (Archimedes' hat-box theorem: a sphere's surface between two parallel
// planes is 2 pi R times their distance).

#include <algorithm>
#include <cmath>

#include "engine/tool_force.h"

namespace hapvox::engine {
namespace {

// The line's reach outside the pole and inside it, in voxels along the grid axis it runs
// on: along an axis at 55 degrees to n a partial-volume ramp spans 3 voxels, and the four
// columns a read mixes enter the material up to 2 voxels apart.
constexpr int kOutsideVoxels = 8;
constexpr int kInsideVoxels = 6;

}  // namespace

PoleDepth ToolForceModel::pole_depth(const Vec3d& x_mm, const Vec3d& n, ToolForceState& s) const {
  PoleDepth result;
  if (!(n.squaredNorm() > 0.0)) return result;
  // The line runs along the grid axis closest to n, into the material. Along an axis the
  // trilinear read is linear between voxel centres, so its integral is exact, and over a
  // plane face it is the bilinear mean of four columns' material, each exact for a
  // partial-volume edge: the line puts a flat face where its voxels say, whatever the
  // face's tilt or offset against the grid. (A line along n itself reads the trilinear
  // cells at a slant: up to 0.07 h off along a body diagonal through the voxel centres,
  // and different at each sub-voxel position.)
  const Vec3d n_index = field_->direction().transpose() * n;  // n in the grid's frame
  int axis = 0;
  n_index.cwiseAbs().maxCoeff(&axis);
  const double sign = n_index[axis] > 0.0 ? 1.0 : -1.0;
  const double h_mm = field_->voxel_size_mm()[axis];
  const double along_n = std::abs(n_index[axis]);  // cos of the line's angle to n
  const Vec3d pole_index = field_->world_to_index(x_mm + tool_radius_mm() * n);
  auto density_at = [&](double q) {  // q: index coordinate along the axis
    Vec3d p = pole_index;
    p[axis] = q;
    return double(sample_density(p.cast<float>(), s));
  };
  const double q_pole = pole_index[axis];
  // Inward, knot by knot, to where the read stops changing (two equal voxel centres at
  // the surface density or more): the material's interior density, however thin it is.
  double q_in = sign > 0.0 ? std::floor(q_pole) + 1.0 : std::ceil(q_pole) - 1.0;
  double interior = density_at(q_in);
  bool solid = false;
  for (int k = 0; k < kInsideVoxels && !solid; ++k) {
    const double next = density_at(q_in + sign);
    solid = next == interior && interior >= surface_density_;
    if (!solid) {
      q_in += sign;
      interior = next;
    }
  }
  if (!solid) return result;  // no interior within reach
  // A ramp more than two voxels above the pole: S's cap is the full depth, and the
  // surface beyond the line's reach.
  if (density_at(q_pole - 2.0 * sign) >= interior) return result;
  // Outward, knot by knot, to the first empty voxel centre.
  double q_out = sign > 0.0 ? std::ceil(q_pole) - 1.0 : std::floor(q_pole) + 1.0;
  bool empty = false;
  for (int k = 0; k < kOutsideVoxels && !empty; ++k) {
    empty = density_at(q_out) <= 0.01 * interior;
    if (!empty) q_out -= sign;
  }
  if (!empty) return result;  // material above the line
  // Exact integrals of the piecewise-linear read, in voxels along the axis.
  auto integral = [&](double from, double to) {
    const double lo = std::min(from, to), hi = std::max(from, to);
    double sum = 0.0, q = lo, value = density_at(lo);
    while (q < hi) {
      const double next = std::min(hi, std::floor(q) + 1.0);
      const double next_value = density_at(next);
      sum += 0.5 * (value + next_value) * (next - q);
      q = next;
      value = next_value;
    }
    return sum;
  };
  const double cap_voxels = integral(q_out, q_pole) / interior;
  const double line_voxels = cap_voxels + integral(q_pole, q_in) / interior;
  const double inside_voxels = std::abs(q_in - q_pole);
  // Where the material on the line would begin if it were solid, measured to the pole,
  // along the axis, then along n (a plane's depths scale by the cosine).
  result.depth_mm = (line_voxels - inside_voxels) * h_mm * along_n;
  result.surface_found = true;
  const double cap_depth_mm = cap_voxels * h_mm * along_n;
  // The Hertz radius from S reads a cap of depth cap_depth_mm where the surface stands
  // depth_mm above the pole: a^2 scales by their ratio (bounded: a contact whose line
  // misses the ramp, an edge's, keeps at most twice S's radius squared).
  result.ramp_factor =
      cap_depth_mm > 0.0 ? std::clamp(result.depth_mm / cap_depth_mm, 0.0, 2.0) : 1.0;
  return result;
}

}  // namespace hapvox::engine
