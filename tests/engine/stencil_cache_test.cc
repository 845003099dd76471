#include "engine/stencil_cache.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <random>
#include <vector>

#include "engine/trilinear_reference.h"

namespace hapvox::engine {
namespace {

using fixtures::make_mixed_grid;
using fixtures::trilinear_reference;

// 301 points (not a whole number of blocks) on a sphere of radius 5 voxels.
std::vector<Eigen::Vector3f> sphere_offsets() {
  std::mt19937 rng(3);
  std::normal_distribution<float> gauss;
  std::vector<Eigen::Vector3f> offsets;
  for (int k = 0; k < 301; ++k) {
    offsets.push_back(5.0f * Eigen::Vector3f(gauss(rng), gauss(rng), gauss(rng)).normalized());
  }
  return offsets;
}

void expect_densities_equal_the_grids(const float* rho, const std::vector<Eigen::Vector3f>& offsets,
                                      const Eigen::Vector3f& center,
                                      openvdb::FloatGrid::ConstAccessor& a) {
  for (std::size_t k = 0; k < offsets.size(); ++k) {
    const float want = trilinear_reference(a, center + offsets[k]);
    ASSERT_EQ(std::bit_cast<std::uint32_t>(rho[k]), std::bit_cast<std::uint32_t>(want))
        << "point " << k << " at " << (center + offsets[k]).transpose();
  }
}

TEST(StencilCache, DensitiesEqualTheGridsAtEveryPointAsTheCentreMoves) {
  const auto grid = make_mixed_grid();
  auto a = grid->getConstAccessor();
  const std::vector<Eigen::Vector3f> offsets = sphere_offsets();
  LeafWindow window;
  window.reserve(Eigen::Vector3d::Constant(5.0));
  StencilCache cache;
  cache.reserve(offsets);
  // A tool moving 10 um a tick across the tile at [0, 8)^3 and through negative indices,
  // then jumping.
  Eigen::Vector3d center(-6.2, 2.1, 3.7);
  std::uint64_t refills_before = 0;
  for (int tick = 0; tick < 1500; ++tick) {
    center += tick == 1000 ? Eigen::Vector3d(3.0, -9.0, 1.5) : Eigen::Vector3d(0.01, 0.004, -0.002);
    ASSERT_TRUE(window.cover(center, a));
    const Eigen::Vector3f c = center.cast<float>();
    expect_densities_equal_the_grids(cache.sample(c, window), offsets, c, a);
    if (tick == 0) {
      EXPECT_GE(cache.refills(), offsets.size());  // every stencil read once
      refills_before = cache.refills();
    }
  }
  // A stencil is read again only when its point crosses a voxel face: the path crosses
  // 16 + 8 faces along its three axes, and jumps once, so about 25 reads a point (not
  // 1,500, one a tick).
  EXPECT_LT(cache.refills() - refills_before, 30 * offsets.size());
}

TEST(StencilCache, ReadsTheNewValuesAfterInvalidate) {
  const auto grid = make_mixed_grid();
  const std::vector<Eigen::Vector3f> offsets = sphere_offsets();
  LeafWindow window;
  window.reserve(Eigen::Vector3d::Constant(5.0));
  StencilCache cache;
  cache.reserve(offsets);
  const Eigen::Vector3f c(12.3f, 11.9f, 12.6f);
  {
    auto a = grid->getConstAccessor();
    ASSERT_TRUE(window.cover(c.cast<double>(), a));
    cache.sample(c, window);
  }
  // The relaxation's change: every voxel around the tool a little denser.
  for (auto leaf = grid->tree().beginLeaf(); leaf; ++leaf)
    for (auto v = leaf->beginValueOn(); v; ++v) v.setValue(0.5f * v.getValue() + 0.25f);
  window.invalidate();
  cache.invalidate();
  auto a = grid->getConstAccessor();
  ASSERT_TRUE(window.cover(c.cast<double>(), a));
  expect_densities_equal_the_grids(cache.sample(c, window), offsets, c, a);
}

}  // namespace
}  // namespace hapvox::engine
