// MassGrid's deletion (Prados et al. section 4.3, step 1): which voxels a surface change
// visits, and what it does to each. See apply_deletion's comment in engine/relax.h for why
// the voxels it leaves out cannot change.

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

#include "engine/check.h"
#include "engine/relax.h"

namespace hapvox::engine {
namespace {

// The z-interval (mm) where the vertical line through (x, y) lies within `radius` of the
// segment ab: the hull of its intersections with the two end spheres and the cylinder
// (the capsule is convex, so the union of the three is one interval). False if empty.
bool capsule_z_span(double x, double y, const Vec3d& a, const Vec3d& b, double radius, double& z_lo,
                    double& z_hi) {
  z_lo = INFINITY;
  z_hi = -INFINITY;
  for (const Vec3d* end : {&a, &b}) {
    if (end == &b && b == a) break;  // a sphere: one end
    const double h2 =
        radius * radius - (x - end->x()) * (x - end->x()) - (y - end->y()) * (y - end->y());
    if (h2 <= 0.0) continue;
    const double h = std::sqrt(h2);
    z_lo = std::min(z_lo, end->z() - h);
    z_hi = std::max(z_hi, end->z() + h);
  }
  const Vec3d ab = b - a;
  const double length = ab.norm();
  if (length > 0.0) {
    // Points p(z) = w + z e_z relative to a; axis u. Perpendicular part q(z) = q0 + z qz.
    const Vec3d u = ab / length;
    const Vec3d w(x - a.x(), y - a.y(), -a.z());
    const Vec3d q0 = w - w.dot(u) * u;
    const Vec3d qz = Vec3d::UnitZ() - u.z() * u;
    const double qa = qz.squaredNorm(), qb = 2.0 * q0.dot(qz),
                 qc = q0.squaredNorm() - radius * radius;
    double c_lo = -INFINITY, c_hi = INFINITY;
    bool hit = true;
    if (qa > 1e-12) {
      const double disc = qb * qb - 4.0 * qa * qc;
      if (disc <= 0.0) {
        hit = false;
      } else {
        c_lo = (-qb - std::sqrt(disc)) / (2.0 * qa);
        c_hi = (-qb + std::sqrt(disc)) / (2.0 * qa);
      }
    } else if (qc >= 0.0) {
      hit = false;  // line parallel to the axis, outside the cylinder
    }
    // Within the slab 0 <= (p - a).u <= length: w.u + z u.z in [0, length].
    if (hit && std::abs(u.z()) > 1e-12) {
      const double t0 = (0.0 - w.dot(u)) / u.z(), t1 = (length - w.dot(u)) / u.z();
      c_lo = std::max(c_lo, std::min(t0, t1));
      c_hi = std::min(c_hi, std::max(t0, t1));
    } else if (hit) {
      hit = w.dot(u) >= 0.0 && w.dot(u) <= length;
    }
    if (hit && c_lo < c_hi) {
      z_lo = std::min(z_lo, c_lo);
      z_hi = std::max(z_hi, c_hi);
    }
  }
  return z_lo < z_hi;
}

openvdb::Coord to_coord(const Vec3d& v) {
  return openvdb::Coord(static_cast<int>(std::lround(v.x())), static_cast<int>(std::lround(v.y())),
                        static_cast<int>(std::lround(v.z())));
}

// Bit k - k0 set for each k of [k_lo, k_hi] within a leaf's column k0 ... k0 + 7.
std::uint32_t column_bits(int k_lo, int k_hi, int k0) {
  const int lo = std::max(k_lo - k0, 0), hi = std::min(k_hi - k0, 7);
  if (lo > hi) return 0;
  return ((2u << hi) - 1u) & ~((1u << lo) - 1u);
}

// The vector from the segment ab's nearest point to p.
inline Vec3d from_segment(const Vec3d& p_mm, const Vec3d& a_mm, const Vec3d& b_mm) {
  // A sphere: what the segment's formula gives for t = 0 and ab = 0, bit for bit.
  if (a_mm == b_mm) return p_mm - a_mm;
  const Vec3d ab = b_mm - a_mm;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p_mm - a_mm).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return p_mm - (a_mm + t * ab);
}

// MassGrid::tool_coverage for the vector r from the segment (dist = |r|, as r.norm() is).
inline double coverage_at(const Vec3d& r, double dist, double radius_mm, const Vec3d& voxel_mm) {
  // The voxel's extent across the tool's surface: the width of the box h along r.
  const double width = dist > 0.0 ? r.cwiseAbs().dot(voxel_mm) / dist : voxel_mm.maxCoeff();
  return std::clamp((radius_mm - dist) / width + 0.5, 0.0, 1.0);
}

constexpr int kLeafSide = openvdb::Int32Grid::TreeType::LeafNodeType::DIM;
static_assert(kLeafSide == 8, "a leaf's column is one byte of its value mask");

}  // namespace

double MassGrid::tool_coverage(const Vec3d& p_mm, const Vec3d& a_mm, const Vec3d& b_mm,
                               double radius_mm) const {
  const Vec3d r = from_segment(p_mm, a_mm, b_mm);
  return coverage_at(r, r.norm(), radius_mm, voxel_size_mm_);
}

bool MassGrid::covered_in_band(const Vec3d& r_mm, double dist2_mm2) const {
  return coverage_at(r_mm, std::sqrt(dist2_mm2), tool_radius_mm_, voxel_size_mm_) > 0.0;
}

double MassGrid::sweep_coverage(const Sweep& s, const Vec3d& p_mm) const {
  // A voxel's width across the surface is at most |h|, so the ramp is 0 beyond r + |h|/2 and
  // 1 within r - |h|/2: those need no square root. A micron of margin leaves the rounding
  // at the bounds to the formula, which gives the same 0 or 1 there.
  const Vec3d r = from_segment(p_mm, s.a_mm, s.b_mm);
  const double dist2 = r.squaredNorm();
  if (dist2 >= s.zero_beyond_mm2) return 0.0;
  if (dist2 <= s.whole_within_mm2) return 1.0;
  return coverage_at(r, std::sqrt(dist2), s.radius_mm, voxel_size_mm_);
}

std::size_t MassGrid::apply_deletion(const SurfaceChange& change) {
  HAPVOX_CHECK_GT(change.radius_mm, 0.0);
  // Work in index space scaled back to mm per axis (voxels may be anisotropic), in the grid
  // frame: the world offsets from the origin turned onto the index axes.
  const Mat3d to_grid = direction_.transpose();
  Sweep s;
  s.a_mm = to_grid * (change.from_mm - origin_mm_);
  s.b_mm = to_grid * (change.position_mm - origin_mm_);
  s.radius_mm = change.radius_mm;
  s.push = (to_grid * change.direction).normalized();
  s.step_mm = 0.5 * voxel_size_mm_.minCoeff();
  // Voxels the tool's surface crosses are covered in part: the sweep reaches half a voxel
  // diagonal beyond the radius.
  s.reach_mm = s.radius_mm + 0.5 * voxel_size_mm_.norm();
  s.zero_beyond_mm2 = (s.reach_mm + 1e-3) * (s.reach_mm + 1e-3);
  const double whole_within_mm = s.radius_mm - 0.5 * voxel_size_mm_.norm() - 1e-3;
  s.whole_within_mm2 = whole_within_mm > 0.0 ? whole_within_mm * whole_within_mm : -1.0;
  // The last sweep's core, where it covered every voxel whole (less a thousandth of a
  // millimetre for rounding).
  s.core_a_mm = last_from_mm_;
  s.core_b_mm = last_to_mm_;
  s.core_radius_mm = tool_radius_mm_ - 0.5 * voxel_size_mm_.norm() - 1e-3;
  s.skip_core = skip_swept_voxels_ && has_tool_ && sweep_empty_ && s.core_radius_mm > 0.0;
  last_from_mm_ = s.a_mm;
  last_to_mm_ = s.b_mm;
  // The sweep relaxation keeps out of, through index space as before issue 29 (the same
  // endpoints to the last bit, so the same voxels).
  tool_a_mm_ = s.a_mm.cwiseQuotient(voxel_size_mm_).cwiseProduct(voxel_size_mm_);
  tool_b_mm_ = s.b_mm.cwiseQuotient(voxel_size_mm_).cwiseProduct(voxel_size_mm_);
  tool_radius_mm_ = s.radius_mm;
  // under_tool's from_segment, taken apart: a sphere when the ends are equal.
  tool_ab_mm_ = tool_b_mm_ - tool_a_mm_;
  tool_len2_mm2_ = tool_a_mm_ == tool_b_mm_ ? -1.0 : tool_ab_mm_.squaredNorm();
  const double covers_mm = s.radius_mm + 0.5 * voxel_size_mm_.minCoeff() - 1e-3;
  tool_covers_within_mm2_ = covers_mm > 0.0 ? covers_mm * covers_mm : -1.0;
  tool_misses_beyond_mm2_ = s.zero_beyond_mm2;  // coverage 0 beyond the same bound
  has_tool_ = true;
  for (const openvdb::Coord& ijk : walled_in_) activate_if_over(ijk, accessor_.getValue(ijk));
  walled_in_.clear();
  const Vec3d lo =
      (s.a_mm.cwiseMin(s.b_mm) - Vec3d::Constant(s.reach_mm)).cwiseQuotient(voxel_size_mm_);
  const Vec3d hi =
      (s.a_mm.cwiseMax(s.b_mm) + Vec3d::Constant(s.reach_mm)).cwiseQuotient(voxel_size_mm_);
  s.lo = openvdb::Coord(static_cast<int>(std::floor(lo.x())), static_cast<int>(std::floor(lo.y())),
                        static_cast<int>(std::floor(lo.z())));
  s.hi = openvdb::Coord(static_cast<int>(std::ceil(hi.x())), static_cast<int>(std::ceil(hi.y())),
                        static_cast<int>(std::ceil(hi.z())));
  s.reference = !skip_swept_voxels_;
  const std::size_t emptied = s.reference ? delete_every_voxel(s) : delete_in_leaves(s);
  work_.deleted_voxels += emptied;
  sweep_empty_ = true;
  return emptied;
}

bool MassGrid::column_span(const Sweep& s, int i, int j, int& k_lo, int& k_hi) const {
  // One voxel of slack each way; delete_voxel's exact test decides.
  double z_lo_mm, z_hi_mm;
  if (!capsule_z_span(i * voxel_size_mm_.x(), j * voxel_size_mm_.y(), s.a_mm, s.b_mm, s.reach_mm,
                      z_lo_mm, z_hi_mm)) {
    return false;
  }
  k_lo = std::max(s.lo.z(), static_cast<int>(std::floor(z_lo_mm / voxel_size_mm_.z())) - 1);
  k_hi = std::min(s.hi.z(), static_cast<int>(std::ceil(z_hi_mm / voxel_size_mm_.z())) + 1);
  return k_lo <= k_hi;
}

bool MassGrid::core_span(const Sweep& s, int i, int j, int& k_lo, int& k_hi) const {
  // The centres strictly inside the last sweep's core on this column.
  double z_lo_mm, z_hi_mm;
  if (!s.skip_core || !capsule_z_span(i * voxel_size_mm_.x(), j * voxel_size_mm_.y(), s.core_a_mm,
                                      s.core_b_mm, s.core_radius_mm, z_lo_mm, z_hi_mm)) {
    return false;
  }
  k_lo = static_cast<int>(std::floor(z_lo_mm / voxel_size_mm_.z())) + 1;
  k_hi = static_cast<int>(std::ceil(z_hi_mm / voxel_size_mm_.z())) - 1;
  return k_lo <= k_hi;
}

std::size_t MassGrid::delete_every_voxel(const Sweep& s) {
  std::size_t emptied = 0;
  for (int i = s.lo.x(); i <= s.hi.x(); ++i) {
    for (int j = s.lo.y(); j <= s.hi.y(); ++j) {
      int k_lo, k_hi;
      if (!column_span(s, i, j, k_lo, k_hi)) continue;
      for (int k = k_lo; k <= k_hi; ++k) emptied += delete_voxel(s, openvdb::Coord(i, j, k));
    }
  }
  return emptied;
}

std::size_t MassGrid::delete_in_leaves(const Sweep& s) {
  // Only voxels holding material can lose any, and OpenVDB keeps them active (set() turns an
  // emptied voxel off; the constructor voxelized every active tile): each leaf's value mask
  // says which, a column of eight voxels one byte of it. A region without a leaf holds none.
  // Within a column, the span the sweep reaches less the last sweep's core, both computed
  // once per column for all the leaves it passes through.
  std::size_t emptied = 0;
  const int mask = ~(kLeafSide - 1);
  for (int ox = s.lo.x() & mask; ox <= s.hi.x(); ox += kLeafSide) {
    for (int oy = s.lo.y() & mask; oy <= s.hi.y(); oy += kLeafSide) {
      std::uint64_t known = 0;  // columns of this stack whose spans below are computed
      bool reached[kLeafSide * kLeafSide];
      int k_lo[kLeafSide * kLeafSide], k_hi[kLeafSide * kLeafSide];
      int core_lo[kLeafSide * kLeafSide], core_hi[kLeafSide * kLeafSide];
      for (int oz = s.lo.z() & mask; oz <= s.hi.z(); oz += kLeafSide) {
        const openvdb::Coord origin(ox, oy, oz);
        const auto* leaf = accessor_.probeConstLeaf(origin);
        if (leaf == nullptr) {
          HAPVOX_CHECK(!accessor_.isValueOn(origin));  // no active tiles (see above)
          continue;
        }
        const auto values_on = leaf->getValueMask();  // a copy: deletion turns bits off
        for (int x = 0; x < kLeafSide; ++x) {
          const int i = ox + x;
          const std::uint64_t word = values_on.template getWord<std::uint64_t>(x);
          if (word == 0 || i < s.lo.x() || i > s.hi.x()) continue;
          for (int y = 0; y < kLeafSide; ++y) {
            const int j = oy + y;
            std::uint32_t bits = static_cast<std::uint32_t>(word >> (kLeafSide * y)) & 0xffu;
            if (bits == 0 || j < s.lo.y() || j > s.hi.y()) continue;
            const int c = x * kLeafSide + y;
            if (!(known >> c & 1u)) {
              known |= std::uint64_t{1} << c;
              reached[c] = column_span(s, i, j, k_lo[c], k_hi[c]);
              if (!core_span(s, i, j, core_lo[c], core_hi[c])) {
                // An empty span, set here: core_span may leave both unwritten, and
                // core_lo - 1 of an unwritten int was undefined (UBSan caught INT_MIN - 1).
                core_lo[c] = 0;
                core_hi[c] = -1;
              }
            }
            if (!reached[c]) continue;
            bits &= column_bits(k_lo[c], k_hi[c], oz) & ~column_bits(core_lo[c], core_hi[c], oz);
            for (; bits != 0; bits &= bits - 1) {
              const int k = oz + std::countr_zero(bits);
              emptied += delete_voxel(s, openvdb::Coord(i, j, k));
            }
          }
        }
      }
    }
  }
  return emptied;
}

bool MassGrid::delete_voxel(const Sweep& s, const openvdb::Coord& source) {
  ++work_.swept_voxels;
  const Vec3d p = Vec3d(source.x(), source.y(), source.z()).cwiseProduct(voxel_size_mm_);
  // Partial volume: the voxel keeps what fits in the part the tool does not cover, so the
  // surface follows the sphere within a voxel and a stroke feels smooth.
  const double covered =
      s.reference ? tool_coverage(p, s.a_mm, s.b_mm, s.radius_mm) : sweep_coverage(s, p);
  if (covered <= 0.0) return false;
  const std::int32_t units = accessor_.getValue(source);
  if (units <= 0) return false;
  const auto room = static_cast<std::int32_t>(std::floor(normal_units_ * (1.0 - covered)));
  if (units <= room) return false;
  const std::int32_t removed = units - room;
  // March along the push until the voxel centre leaves the swept sphere and its covered
  // rim; for a sphere, start a voxel short of where the ray leaves it.
  Vec3d q = p;
  if (s.a_mm == s.b_mm) {
    const Vec3d pa = p - s.a_mm;
    const double along = pa.dot(s.push);
    const double exit_mm =
        -along +
        std::sqrt(std::max(0.0, along * along - pa.squaredNorm() + s.radius_mm * s.radius_mm));
    const double skip_steps = std::floor(exit_mm / s.step_mm) - 2.0;
    if (skip_steps > 0.0) q += skip_steps * s.step_mm * s.push;
  }
  openvdb::Coord target = source;
  for (int guard = 0; guard < 100000; ++guard) {
    q += s.step_mm * s.push;
    const openvdb::Coord next = to_coord(q.cwiseQuotient(voxel_size_mm_));
    if (next == target && !s.reference) continue;  // the voxel just tested (or the source)
    target = next;
    const Vec3d centre = Vec3d(target.x(), target.y(), target.z()).cwiseProduct(voxel_size_mm_);
    const double target_covered = s.reference ? tool_coverage(centre, s.a_mm, s.b_mm, s.radius_mm)
                                              : sweep_coverage(s, centre);
    if (target_covered <= 0.0) break;
  }
  const std::int64_t target_sum = std::int64_t{accessor_.getValue(target)} + removed;
  HAPVOX_CHECK_LE(target_sum, std::int64_t{INT32_MAX});
  const auto target_units = static_cast<std::int32_t>(target_sum);
  set(source, room);
  set(target, target_units);
  carved_accessor_.setValueOn(source);
  carved_accessor_.setValueOff(target);
  activate_if_over(target, target_units);
  work_.moved_units += static_cast<std::uint64_t>(removed);
  return true;
}

}  // namespace hapvox::engine
