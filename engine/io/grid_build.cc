#include "engine/io/grid_build.h"

#include <algorithm>

namespace hapvox::engine::io {

openvdb::FloatGrid::Ptr build_grid(const Vec3i& dims,
                                   const std::function<float(int, int, int)>& density) {
  using Leaf = openvdb::FloatTree::LeafNodeType;
  constexpr int kDim = static_cast<int>(Leaf::DIM);
  auto grid = openvdb::FloatGrid::create(0.0f);
  auto& tree = grid->tree();
  for (int bz = 0; bz < dims.z(); bz += kDim) {
    for (int by = 0; by < dims.y(); by += kDim) {
      for (int bx = 0; bx < dims.x(); bx += kDim) {
        Leaf* leaf = nullptr;
        const int ez = std::min(bz + kDim, dims.z());
        const int ey = std::min(by + kDim, dims.y());
        const int ex = std::min(bx + kDim, dims.x());
        for (int z = bz; z < ez; ++z) {
          for (int y = by; y < ey; ++y) {
            for (int x = bx; x < ex; ++x) {
              const float d = density(x, y, z);
              if (!(d > 0.0f)) continue;
              if (leaf == nullptr) leaf = tree.touchLeaf(openvdb::Coord(bx, by, bz));
              leaf->setValueOn(Leaf::coordToOffset(openvdb::Coord(x, y, z)), d);
            }
          }
        }
      }
    }
  }
  return grid;
}

}  // namespace hapvox::engine::io
