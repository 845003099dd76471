#include "engine/visited_set.h"

#include <gtest/gtest.h>

#include <random>
#include <set>
#include <tuple>

namespace hapvox::engine {
namespace {

using openvdb::Coord;
using openvdb::CoordBBox;

// A box whose rows (x runs of 70 voxels) straddle 64-bit words at every offset.
CoordBBox odd_box() { return CoordBBox(Coord(-3, -2, -1), Coord(66, 9, 7)); }

TEST(VisitedSet, MarksEachVoxelOnceInsideAndOutsideItsBox) {
  VisitedSet visited(odd_box());
  ASSERT_TRUE(visited.dense());
  for (const Coord ijk : {Coord(-3, -2, -1), Coord(66, 9, 7), Coord(0, 0, 0), Coord(63, 4, 2),
                          Coord(64, 4, 2), Coord(-4, 0, 0), Coord(67, 9, 7), Coord(1000, -5, 3)}) {
    EXPECT_FALSE(visited.contains(ijk)) << ijk;
    EXPECT_TRUE(visited.insert(ijk)) << ijk;
    EXPECT_TRUE(visited.contains(ijk)) << ijk;
    EXPECT_FALSE(visited.insert(ijk)) << ijk;
  }
  // Neighbours of a mark are not marked (no bit bleeds into the next voxel or row).
  EXPECT_FALSE(visited.contains(Coord(62, 4, 2)));
  EXPECT_FALSE(visited.contains(Coord(65, 4, 2)));
  EXPECT_FALSE(visited.contains(Coord(63, 5, 2)));
  EXPECT_FALSE(visited.contains(Coord(63, 4, 3)));
}

TEST(VisitedSet, ClearForgetsEveryMarkAndOnlyMarksAreEverSeen) {
  // Random marks against a std::set, over several rounds of clear(): a clear that left a
  // bit of some row or word (or the sparse part) set would show as a stale contains().
  VisitedSet visited(odd_box());
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> x(-6, 69), y(-4, 11), z(-3, 9);
  for (int round = 0; round < 5; ++round) {
    std::set<std::tuple<int, int, int>> want;
    for (int n = 0; n < 400; ++n) {
      const Coord ijk(x(rng), y(rng), z(rng));
      const bool fresh = want.emplace(ijk.x(), ijk.y(), ijk.z()).second;
      EXPECT_EQ(visited.insert(ijk), fresh) << ijk;
    }
    for (int k = -3; k <= 9; ++k) {
      for (int j = -4; j <= 11; ++j) {
        for (int i = -6; i <= 69; ++i) {
          EXPECT_EQ(visited.contains(Coord(i, j, k)), want.count({i, j, k}) == 1) << Coord(i, j, k);
        }
      }
    }
    visited.clear();
    for (const auto& [i, j, k] : want) EXPECT_FALSE(visited.contains(Coord(i, j, k)));
  }
}

TEST(VisitedSet, ABoxTooLargeToHoldDenselyUsesTheSparseMaskAlone) {
  VisitedSet visited(CoordBBox(Coord(0), Coord(1 << 11, 1 << 11, 1 << 10)));
  EXPECT_FALSE(visited.dense());
  EXPECT_TRUE(visited.insert(Coord(5, 6, 7)));
  EXPECT_FALSE(visited.insert(Coord(5, 6, 7)));
  visited.clear();
  EXPECT_FALSE(visited.contains(Coord(5, 6, 7)));
  EXPECT_TRUE(visited.insert(Coord(5, 6, 7)));
}

}  // namespace
}  // namespace hapvox::engine
