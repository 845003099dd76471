#include "engine/leaf_window.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <limits>
#include <random>

#include "engine/trilinear_reference.h"

namespace hapvox::engine {
namespace {

using fixtures::make_mixed_grid;
using fixtures::trilinear_reference;

// Reads at random points within `reach` of `center`, each compared bit for bit with the
// accessor's; returns how many stencils straddled leaves.
int expect_reads_equal_the_grids(const LeafWindow& window, openvdb::FloatGrid::ConstAccessor& a,
                                 const Eigen::Vector3f& center, float reach) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> offset(-reach, reach);
  int straddling = 0;
  for (int n = 0; n < 20000; ++n) {
    const Eigen::Vector3f q = center + Eigen::Vector3f(offset(rng), offset(rng), offset(rng));
    EXPECT_TRUE(window.contains(q)) << q.transpose();
    const float got = window.sample(q);
    const float want = trilinear_reference(a, q);
    EXPECT_EQ(std::bit_cast<std::uint32_t>(got), std::bit_cast<std::uint32_t>(want))
        << q.transpose() << ": " << got << " vs " << want;
    const Eigen::Vector3f f = q.array().floor();
    straddling += (int(f.x()) & 7) == 7 || (int(f.y()) & 7) == 7 || (int(f.z()) & 7) == 7;
  }
  return straddling;
}

TEST(LeafWindow, ReadsTheGridsTrilinearDensityBitForBit) {
  const auto grid = make_mixed_grid();
  auto a = grid->getConstAccessor();
  LeafWindow window;
  window.reserve(Eigen::Vector3d::Constant(14.0));
  // Around the tile at [0, 8)^3, through random leaves (negative indices) out to the
  // background past index 24.
  const Eigen::Vector3d center(3.3, -1.7, 9.6);
  ASSERT_TRUE(window.cover(center, a));
  const int straddling = expect_reads_equal_the_grids(window, a, center.cast<float>(), 14.0f);
  EXPECT_GT(straddling, 5000);  // a third of the stencils span leaves
}

TEST(LeafWindow, FollowsTheCentreAndRebuildsOnlyWhenItLeaves) {
  const auto grid = make_mixed_grid();
  auto a = grid->getConstAccessor();
  LeafWindow window;
  window.reserve(Eigen::Vector3d::Constant(6.0));
  Eigen::Vector3d center(4.5, 4.5, 4.5);
  ASSERT_TRUE(window.cover(center, a));
  EXPECT_EQ(window.rebuilds(), 1u);
  for (int step = 0; step < 100; ++step) {  // a tool moving 10 um a tick: 1 mm
    center.x() += 0.01;
    ASSERT_TRUE(window.cover(center, a));
  }
  EXPECT_EQ(window.rebuilds(), 1u);
  center += Eigen::Vector3d(-20.0, 13.0, 7.0);
  ASSERT_TRUE(window.cover(center, a));
  EXPECT_EQ(window.rebuilds(), 2u);
  expect_reads_equal_the_grids(window, a, center.cast<float>(), 6.0f);
  // Points beyond the reach and its margin are not in the window (callers read them
  // through the accessor).
  EXPECT_FALSE(window.contains(center.cast<float>() + Eigen::Vector3f(40.0f, 0.0f, 0.0f)));
  EXPECT_FALSE(window.contains(Eigen::Vector3f(std::nanf(""), 0.0f, 0.0f)));
}

TEST(LeafWindow, ReadsTheGridAsItIsAfterInvalidate) {
  const auto grid = make_mixed_grid();
  LeafWindow window;
  window.reserve(Eigen::Vector3d::Constant(6.0));
  const Eigen::Vector3d center(28.0, 4.0, 4.0);  // leaves up to x = 24, background beyond
  {
    auto a = grid->getConstAccessor();
    ASSERT_TRUE(window.cover(center, a));
    EXPECT_EQ(window.sample(Eigen::Vector3f(30.5f, 4.0f, 4.0f)), 0.0f);
  }
  grid->tree().setValueOn(openvdb::Coord(31, 4, 4), 0.8f);  // a new leaf in the background
  window.invalidate();
  auto a = grid->getConstAccessor();
  ASSERT_TRUE(window.cover(center, a));
  EXPECT_EQ(window.rebuilds(), 2u);
  EXPECT_EQ(window.sample(Eigen::Vector3f(30.5f, 4.0f, 4.0f)), 0.4f);
  expect_reads_equal_the_grids(window, a, center.cast<float>(), 6.0f);
}

TEST(LeafWindow, RefusesACentreTooFarOutAndAnUnreservedWindow) {
  const auto grid = make_mixed_grid();
  auto a = grid->getConstAccessor();
  LeafWindow unreserved;
  EXPECT_FALSE(unreserved.cover(Eigen::Vector3d::Zero(), a));
  LeafWindow window;
  window.reserve(Eigen::Vector3d::Constant(6.0));
  EXPECT_FALSE(window.cover(Eigen::Vector3d(std::numeric_limits<double>::quiet_NaN(), 0, 0), a));
  EXPECT_FALSE(window.cover(Eigen::Vector3d(0, 1e12, 0), a));  // a trace in nm read as mm
  // Past 2^22 voxels a float no longer holds the reads' positions to a quarter voxel.
  EXPECT_FALSE(window.cover(Eigen::Vector3d(0, 0, 5e6), a));
  EXPECT_EQ(window.rebuilds(), 0u);
}

}  // namespace
}  // namespace hapvox::engine
