#include "render/tet_slicer.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "engine/check.h"

namespace hapvox::render {
namespace {

using Eigen::Vector3d;

// A slice polygon's corner: where it is drawn and the rest point whose material it shows.
struct Corner {
  Vector3d position, rest;
};

void push(SliceMesh& mesh, const std::vector<Corner>& polygon) {
  if (polygon.size() < 3) return;
  const auto base = static_cast<std::uint32_t>(mesh.vertices.size());
  for (const Corner& c : polygon) {
    SliceVertex v{};
    for (int a = 0; a < 3; ++a) {
      v.position[a] = static_cast<float>(c.position[a]);
      v.rest[a] = static_cast<float>(c.rest[a]);
    }
    mesh.vertices.push_back(v);
  }
  for (std::uint32_t i = 1; i + 1 < polygon.size(); ++i) {
    mesh.indices.insert(mesh.indices.end(), {base, base + i, base + i + 1});
  }
}

// Sutherland-Hodgman: the convex polygon cut to the box [lo, hi] (by position), the rest
// point interpolated along with it.
void clip_to_box(std::vector<Corner>& polygon, const Vector3d& lo, const Vector3d& hi,
                 std::vector<Corner>& scratch) {
  for (int axis = 0; axis < 3 && !polygon.empty(); ++axis) {
    for (int side = 0; side < 2 && !polygon.empty(); ++side) {
      // Inside: position[axis] >= lo (side 0) or <= hi (side 1).
      const auto inside = [&](const Corner& c) {
        return side == 0 ? c.position[axis] - lo[axis] : hi[axis] - c.position[axis];
      };
      scratch.clear();
      for (std::size_t i = 0; i < polygon.size(); ++i) {
        const Corner& a = polygon[i];
        const Corner& b = polygon[(i + 1) % polygon.size()];
        const double da = inside(a), db = inside(b);
        if (da >= 0) scratch.push_back(a);
        if ((da >= 0) != (db >= 0)) {
          const double t = da / (da - db);
          scratch.push_back(
              Corner{a.position + t * (b.position - a.position), a.rest + t * (b.rest - a.rest)});
        }
      }
      polygon.swap(scratch);
    }
  }
}

}  // namespace

TetSlicer::TetSlicer(const Vector3d& frame_lo, const Vector3d& frame_hi,
                     const Eigen::Vector3i& dims, int block_voxels)
    : frame_lo_(frame_lo), frame_hi_(frame_hi) {
  HAPVOX_CHECK_GT(block_voxels, 0);
  blocks_ = (dims.array() + block_voxels - 1) / block_voxels;
  const Vector3d voxel_mm = (frame_hi - frame_lo).cwiseQuotient(dims.cast<double>());
  block_mm_ = voxel_mm * block_voxels;
  block_deformed_.assign(static_cast<std::size_t>(blocks_.prod()), 0);
}

void TetSlicer::set_mesh(const engine::fem::TetMesh& mesh) {
  mesh_ = &mesh;
  deformed_mm_ = mesh.rest_mm;
  std::fill(block_deformed_.begin(), block_deformed_.end(), 0);
  sliced_tets_.clear();
}

TetSliceStats TetSlicer::set_displacement(const Eigen::Ref<const Eigen::VectorXd>& displacement_mm,
                                          double threshold_mm) {
  HAPVOX_CHECK(mesh_ != nullptr);
  const engine::fem::TetMesh& mesh = *mesh_;
  HAPVOX_CHECK_EQ(displacement_mm.size(), 3 * mesh.vertex_count());
  TetSliceStats stats;
  std::vector<std::uint8_t> moved(mesh.vertex_count(), 0);
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    const Vector3d u = displacement_mm.segment<3>(3 * v);
    deformed_mm_.col(v) = mesh.rest_mm.col(v) + u;
    moved[v] = u.norm() > threshold_mm;
  }
  std::fill(block_deformed_.begin(), block_deformed_.end(), 0);
  const auto block_range = [&](const Vector3d& lo, const Vector3d& hi, Eigen::Vector3i& b0,
                               Eigen::Vector3i& b1) {
    for (int a = 0; a < 3; ++a) {
      b0[a] = std::clamp(static_cast<int>(std::floor((lo[a] - frame_lo_[a]) / block_mm_[a])), 0,
                         blocks_[a] - 1);
      b1[a] = std::clamp(static_cast<int>(std::floor((hi[a] - frame_lo_[a]) / block_mm_[a])), 0,
                         blocks_[a] - 1);
    }
  };
  const auto box_of = [&](const Eigen::Matrix3Xd& x, const engine::fem::Tet& tet, Vector3d& lo,
                          Vector3d& hi) {
    lo = hi = x.col(tet[0]);
    for (int k = 1; k < 4; ++k) {
      lo = lo.cwiseMin(x.col(tet[k]));
      hi = hi.cwiseMax(x.col(tet[k]));
    }
  };
  Eigen::Vector3i b0, b1;
  Vector3d lo, hi;
  for (const engine::fem::Tet& tet : mesh.tets) {
    if (!(moved[tet[0]] || moved[tet[1]] || moved[tet[2]] || moved[tet[3]])) continue;
    ++stats.moved_tets;
    for (const Eigen::Matrix3Xd* x :
         {&mesh.rest_mm, static_cast<const Eigen::Matrix3Xd*>(&deformed_mm_)}) {
      box_of(*x, tet, lo, hi);
      block_range(lo, hi, b0, b1);
      for (int z = b0.z(); z <= b1.z(); ++z) {
        for (int y = b0.y(); y <= b1.y(); ++y) {
          for (int x_ = b0.x(); x_ <= b1.x(); ++x_) {
            block_deformed_[(static_cast<std::size_t>(z) * blocks_.y() + y) * blocks_.x() + x_] = 1;
          }
        }
      }
    }
  }
  // The tets to cut: every one whose deformed box reaches a deformed block.
  sliced_tets_.clear();
  for (int t = 0; t < mesh.tet_count(); ++t) {
    box_of(deformed_mm_, mesh.tets[t], lo, hi);
    block_range(lo, hi, b0, b1);
    bool reaches = false;
    for (int z = b0.z(); z <= b1.z() && !reaches; ++z) {
      for (int y = b0.y(); y <= b1.y() && !reaches; ++y) {
        for (int x_ = b0.x(); x_ <= b1.x() && !reaches; ++x_) {
          reaches =
              block_deformed_[(static_cast<std::size_t>(z) * blocks_.y() + y) * blocks_.x() + x_];
        }
      }
    }
    if (reaches) sliced_tets_.push_back(t);
  }
  stats.deformed_blocks =
      static_cast<std::size_t>(std::count(block_deformed_.begin(), block_deformed_.end(), 1));
  stats.sliced_tets = sliced_tets_.size();
  return stats;
}

void TetSlicer::build(const Vector3d& lo, const Vector3d& hi, const Vector3d& view_direction,
                      int slices, SliceMesh& out) const {
  HAPVOX_CHECK(mesh_ != nullptr);
  HAPVOX_CHECK_GT(slices, 0);
  const engine::fem::TetMesh& mesh = *mesh_;
  out.vertices.clear();
  out.indices.clear();
  out.slice_first_index.clear();
  const Vector3d n = view_direction.normalized();
  // The plane lattice of build_slice_mesh: `slices` planes across the frame, farthest first.
  double frame_min = INFINITY, frame_max = -INFINITY;
  for (int k = 0; k < 8; ++k) {
    const Vector3d c((k & 1) ? frame_hi_.x() : frame_lo_.x(),
                     (k & 2) ? frame_hi_.y() : frame_lo_.y(),
                     (k & 4) ? frame_hi_.z() : frame_lo_.z());
    frame_min = std::min(frame_min, n.dot(c));
    frame_max = std::max(frame_max, n.dot(c));
  }
  const double spacing = (frame_max - frame_min) / slices;
  out.slices = slices;
  out.slice_spacing_mm = spacing;

  // Each cut tet's range along n, at its deformed place.
  std::vector<std::array<double, 2>> range(sliced_tets_.size());
  for (std::size_t i = 0; i < sliced_tets_.size(); ++i) {
    const engine::fem::Tet& tet = mesh.tets[sliced_tets_[i]];
    double s0 = INFINITY, s1 = -INFINITY;
    for (const std::int32_t v : tet) {
      const double s = n.dot(deformed_mm_.col(v));
      s0 = std::min(s0, s);
      s1 = std::max(s1, s);
    }
    range[i] = {s0, s1};
  }
  std::vector<Corner> polygon, scratch;
  for (int k = 0; k < slices; ++k) {
    out.slice_first_index.push_back(static_cast<std::uint32_t>(out.indices.size()));
    const double s = frame_max - (k + 0.5) * spacing;
    // Plain polygons through the blocks nothing deformed, cut to the visible box.
    for (int z = 0; z < blocks_.z(); ++z) {
      for (int y = 0; y < blocks_.y(); ++y) {
        for (int x = 0; x < blocks_.x(); ++x) {
          if (block_deformed_[(static_cast<std::size_t>(z) * blocks_.y() + y) * blocks_.x() + x]) {
            continue;
          }
          const Vector3d block_lo = frame_lo_ + Vector3d(x, y, z).cwiseProduct(block_mm_);
          const Vector3d b_lo = block_lo.cwiseMax(lo);
          const Vector3d b_hi = (block_lo + block_mm_).cwiseMin(frame_hi_).cwiseMin(hi);
          if ((b_hi - b_lo).minCoeff() <= 0) continue;
          polygon.clear();
          for (const Vector3d& p : slice_polygon(b_lo, b_hi, n, s)) polygon.push_back({p, p});
          push(out, polygon);
        }
      }
    }
    // The tets reaching deformed blocks, cut at their deformed place and clipped to each
    // deformed block they reach.
    for (std::size_t i = 0; i < sliced_tets_.size(); ++i) {
      if (s < range[i][0] || s > range[i][1]) continue;
      const engine::fem::Tet& tet = mesh.tets[sliced_tets_[i]];
      double d[4];
      for (int a = 0; a < 4; ++a) d[a] = n.dot(deformed_mm_.col(tet[a])) - s;
      std::int32_t above[4], below[4];
      int na = 0, nb = 0;
      for (int a = 0; a < 4; ++a) (d[a] > 0 ? above[na++] : below[nb++]) = a;
      if (na == 0 || nb == 0) continue;
      const auto cross = [&](int a, int b) {
        const double t = d[a] / (d[a] - d[b]);
        return Corner{
            deformed_mm_.col(tet[a]) + t * (deformed_mm_.col(tet[b]) - deformed_mm_.col(tet[a])),
            mesh.rest_mm.col(tet[a]) + t * (mesh.rest_mm.col(tet[b]) - mesh.rest_mm.col(tet[a]))};
      };
      std::vector<Corner> piece;
      if (na == 1 || nb == 1) {
        const int lone = na == 1 ? above[0] : below[0];
        const std::int32_t* others = na == 1 ? below : above;
        piece = {cross(lone, others[0]), cross(lone, others[1]), cross(lone, others[2])};
      } else {
        // Two against two: the crossings in order around the quadrilateral.
        piece = {cross(above[0], below[0]), cross(above[0], below[1]), cross(above[1], below[1]),
                 cross(above[1], below[0])};
      }
      Vector3d p_lo = piece[0].position, p_hi = piece[0].position;
      for (const Corner& c : piece) {
        p_lo = p_lo.cwiseMin(c.position);
        p_hi = p_hi.cwiseMax(c.position);
      }
      Eigen::Vector3i b0, b1;
      for (int a = 0; a < 3; ++a) {
        b0[a] = std::clamp(static_cast<int>(std::floor((p_lo[a] - frame_lo_[a]) / block_mm_[a])), 0,
                           blocks_[a] - 1);
        b1[a] = std::clamp(static_cast<int>(std::floor((p_hi[a] - frame_lo_[a]) / block_mm_[a])), 0,
                           blocks_[a] - 1);
      }
      for (int z = b0.z(); z <= b1.z(); ++z) {
        for (int y = b0.y(); y <= b1.y(); ++y) {
          for (int x = b0.x(); x <= b1.x(); ++x) {
            if (!block_deformed_[(static_cast<std::size_t>(z) * blocks_.y() + y) * blocks_.x() +
                                 x]) {
              continue;
            }
            const Vector3d block_lo = frame_lo_ + Vector3d(x, y, z).cwiseProduct(block_mm_);
            const Vector3d block_hi = (block_lo + block_mm_).cwiseMin(frame_hi_);
            polygon = piece;
            clip_to_box(polygon, block_lo, block_hi, scratch);
            push(out, polygon);
          }
        }
      }
    }
  }
  out.slice_first_index.push_back(static_cast<std::uint32_t>(out.indices.size()));
}

}  // namespace hapvox::render
