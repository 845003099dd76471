#include "engine/density_field.h"

#include <cmath>
#include <mutex>

#include "engine/check.h"

namespace hapvox::engine {

void initialize_openvdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

DensityField::DensityField(openvdb::FloatGrid::Ptr grid, const Vec3d& voxel_size_mm,
                           const Vec3d& origin_mm, const Vec3i& dims, const Mat3d& direction)
    : grid_(std::move(grid)),
      voxel_size_mm_(voxel_size_mm),
      origin_mm_(origin_mm),
      dims_(dims),
      direction_(direction),
      axis_aligned_(direction == Mat3d::Identity()) {
  HAPVOX_CHECK(grid_ != nullptr);
  HAPVOX_CHECK_EQ(grid_->background(), 0.0f);
  HAPVOX_CHECK(voxel_size_mm_.minCoeff() > 0.0);
  HAPVOX_CHECK((direction_.transpose() * direction_).isApprox(Mat3d::Identity(), 1e-4));
  // Keep the grid's own transform in step so .vdb files open at the right place, scale and
  // orientation in other tools (Blender, Houdini).
  openvdb::math::MapBase::Ptr map;
  if (axis_aligned_) {
    map = std::make_shared<openvdb::math::ScaleTranslateMap>(
        openvdb::Vec3d(voxel_size_mm.x(), voxel_size_mm.y(), voxel_size_mm.z()),
        openvdb::Vec3d(origin_mm.x(), origin_mm.y(), origin_mm.z()));
  } else {
    // OpenVDB maps row vectors: world = [i j k 1] * M, so row a is axis a's step in world.
    openvdb::Mat4d m = openvdb::Mat4d::identity();
    for (int a = 0; a < 3; ++a) {
      for (int c = 0; c < 3; ++c) m(a, c) = direction_(c, a) * voxel_size_mm_[a];
      m(3, a) = origin_mm_[a];
    }
    map = std::make_shared<openvdb::math::AffineMap>(m);
  }
  grid_->setTransform(std::make_shared<openvdb::math::Transform>(map));
}

namespace {

// Corner `c` (bits x, y, z) of the voxel box [0, dims) in index space: voxel faces.
Vec3d box_corner(const Vec3i& dims, int c) {
  return Vec3d((c & 1) ? dims.x() - 0.5 : -0.5, (c & 2) ? dims.y() - 0.5 : -0.5,
               (c & 4) ? dims.z() - 0.5 : -0.5);
}

}  // namespace

Vec3d DensityField::world_min_mm() const {
  Vec3d lo = index_to_world(box_corner(dims_, 0));
  for (int c = 1; c < 8; ++c) lo = lo.cwiseMin(index_to_world(box_corner(dims_, c)));
  return lo;
}

Vec3d DensityField::world_max_mm() const {
  Vec3d hi = index_to_world(box_corner(dims_, 0));
  for (int c = 1; c < 8; ++c) hi = hi.cwiseMax(index_to_world(box_corner(dims_, c)));
  return hi;
}

double DensityField::sample_world(const Vec3d& p_mm) const {
  const Vec3d q = world_to_index(p_mm);
  const Vec3d base(std::floor(q.x()), std::floor(q.y()), std::floor(q.z()));
  const Vec3d f = q - base;
  const openvdb::Coord c0(static_cast<int>(base.x()), static_cast<int>(base.y()),
                          static_cast<int>(base.z()));
  auto acc = grid_->getConstAccessor();
  double result = 0.0;
  for (int dz = 0; dz < 2; ++dz) {
    for (int dy = 0; dy < 2; ++dy) {
      for (int dx = 0; dx < 2; ++dx) {
        const double w =
            (dx ? f.x() : 1.0 - f.x()) * (dy ? f.y() : 1.0 - f.y()) * (dz ? f.z() : 1.0 - f.z());
        result += w * acc.getValue(c0.offsetBy(dx, dy, dz));
      }
    }
  }
  return result;
}

double DensityField::total_density() const {
  double sum = 0.0;
  for (auto it = grid_->cbeginValueOn(); it; ++it) {
    sum += static_cast<double>(*it) * static_cast<double>(it.getVoxelCount());
  }
  return sum;
}

}  // namespace hapvox::engine
