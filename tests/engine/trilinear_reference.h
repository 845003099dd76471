#pragma once
// The tests' reference read of a density grid: the eight voxels of a point's 2x2x2
// stencil, each through a ValueAccessor, interpolated z, then y, then x (the force path's
// order), and a grid that holds every kind of place a read can meet.

#include <openvdb/openvdb.h>

#include <Eigen/Core>
#include <cmath>
#include <random>

namespace hapvox::engine::fixtures {

inline float trilinear_reference(openvdb::FloatGrid::ConstAccessor& a, const Eigen::Vector3f& q) {
  const float x0 = std::floor(q.x()), y0 = std::floor(q.y()), z0 = std::floor(q.z());
  const float fx = q.x() - x0, fy = q.y() - y0, fz = q.z() - z0;
  const openvdb::Coord c(static_cast<int>(x0), static_cast<int>(y0), static_cast<int>(z0));
  auto v = [&](int dx, int dy, int dz) { return a.getValue(c.offsetBy(dx, dy, dz)); };
  const float a00 = v(0, 0, 0) + fz * (v(0, 0, 1) - v(0, 0, 0));
  const float a01 = v(0, 1, 0) + fz * (v(0, 1, 1) - v(0, 1, 0));
  const float a10 = v(1, 0, 0) + fz * (v(1, 0, 1) - v(1, 0, 0));
  const float a11 = v(1, 1, 0) + fz * (v(1, 1, 1) - v(1, 1, 0));
  const float b0 = a00 + fy * (a01 - a00);
  const float b1 = a10 + fy * (a11 - a10);
  return b0 + fx * (b1 - b0);
}

/// Random densities in leaves over [-16, 24)^3 (negative indices included), a tile where
/// the leaf at [0, 8)^3 would be (density 0.6, no leaf), and the background (0) around.
inline openvdb::FloatGrid::Ptr make_mixed_grid() {
  openvdb::initialize();
  auto grid = openvdb::FloatGrid::create(0.0f);
  auto acc = grid->getAccessor();
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> density(0.0f, 1.0f);
  for (int i = -16; i < 24; ++i)
    for (int j = -16; j < 24; ++j)
      for (int k = -16; k < 24; ++k) acc.setValueOn({i, j, k}, density(rng));
  grid->tree().fill(openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(7)), 0.6f, true);
  return grid;
}

}  // namespace hapvox::engine::fixtures
