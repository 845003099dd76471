#include "render/front_to_back.h"

#include <gtest/gtest.h>

namespace hapvox::render {
namespace {

// Five slices, farthest first, of 1, 0, 2, 1 and 1 triangles (an empty slice: a plane that
// cut nothing drawable).
SliceMesh five_slices() {
  SliceMesh mesh;
  const std::vector<std::vector<std::uint32_t>> slices = {
      {0, 1, 2}, {}, {3, 4, 5, 6, 7, 8}, {9, 10, 11}, {12, 13, 14}};
  for (const auto& slice : slices) {
    mesh.slice_first_index.push_back(static_cast<std::uint32_t>(mesh.indices.size()));
    mesh.indices.insert(mesh.indices.end(), slice.begin(), slice.end());
  }
  mesh.slice_first_index.push_back(static_cast<std::uint32_t>(mesh.indices.size()));
  mesh.slices = 5;
  return mesh;
}

// The nearest slice first, each slice's triangles kept in their order, and a chunk end
// after every `chunk_slices` slices (empty ones counted) and at the end.
TEST(FrontToBack, OrdersSlicesNearestFirstInChunks) {
  const SliceMesh mesh = five_slices();
  std::vector<std::uint32_t> indices;
  std::vector<std::size_t> chunk_ends;
  order_front_to_back(mesh, 2, indices, chunk_ends);
  EXPECT_EQ(indices,
            (std::vector<std::uint32_t>{12, 13, 14, 9, 10, 11, 3, 4, 5, 6, 7, 8, 0, 1, 2}));
  EXPECT_EQ(chunk_ends, (std::vector<std::size_t>{6, 12, 15}));
  order_front_to_back(mesh, 16, indices, chunk_ends);
  EXPECT_EQ(chunk_ends, (std::vector<std::size_t>{15}));
  EXPECT_EQ(indices.size(), mesh.indices.size());
}

}  // namespace
}  // namespace hapvox::render
