// An incision as the renderer's texture shows it: the proxy mesh split along a cut
// (engine/fem/incision.h), opened by the FEM with the two faces prescribed +-width/2, and
// resampled (render/proxy_resample.h). The gap is empty and as wide as asked; the material
// on either side is the material that met at the cut, with nothing smeared across.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "engine/fem/incision.h"
#include "engine/fem/linear_fem.h"
#include "render/proxy_resample.h"

namespace hapvox::render {
namespace {

using Eigen::Vector3d;

constexpr int kN = 48;          // voxels per axis, 1 mm, centres at 0 .. 47 mm
constexpr double kCutY = 27.4;  // between the lattice's vertex planes 23.5 and 31.3
constexpr double kWidth = 6.0;  // mm: six voxels

// Density rising along y (0.2 at y = 0 to 0.8 at y = 47), the same along x and z: the
// material at the cut is 0.2 + 0.6 * 27.4 / 47.
DenseVolume ramp() {
  DenseVolume v;
  v.dims = Eigen::Vector3i::Constant(kN);
  v.lo_mm = Vector3d::Constant(-0.5);
  v.hi_mm = Vector3d::Constant(kN - 0.5);
  v.density.resize(v.voxel_count());
  for (int z = 0; z < kN; ++z) {
    for (int y = 0; y < kN; ++y) {
      for (int x = 0; x < kN; ++x) v.density[v.index(x, y, z)] = float(0.2 + 0.6 * y / (kN - 1.0));
    }
  }
  return v;
}

struct OpenedCut {
  engine::fem::IncisedMesh incised;
  Eigen::VectorXd displacement_mm;
};

// The plane y = kCutY across the whole width, from above the top (z = 52) down to z = 20,
// opened by kWidth; the faces y = 0 and y = 47 held.
OpenedCut open_cut(double width_mm) {
  using namespace engine::fem;
  const TetMesh mesh = regular_lattice({7, 7, 7}, (kN - 1.0) / 6, Vector3d::Zero());
  OpenedCut out{incise(mesh,
                       swept_polyline({Vector3d(-5, kCutY, 52), Vector3d(kN + 5, kCutY, 52)},
                                      Vector3d(0, 0, -32), "cut"),
                       "cut"),
                {}};
  const TetMesh& cut = out.incised.mesh;
  Eigen::VectorXd prescribed = Eigen::VectorXd::Zero(3 * cut.vertex_count());
  std::vector<int> held;
  for (int v = 0; v < cut.vertex_count(); ++v) {
    if (cut.rest_mm(1, v) == 0.0 || cut.rest_mm(1, v) == kN - 1.0) {
      for (int axis = 0; axis < 3; ++axis) held.push_back(3 * v + axis);
    }
  }
  for (const auto& [dof, mm] : opening_displacements(out.incised, width_mm)) {
    held.push_back(dof);
    prescribed(dof) = mm;
  }
  const std::vector<TetMaterial> materials(cut.tet_count(), TetMaterial{3000.0, 0.3});
  const LinearFem fem(cut, materials, held);
  out.displacement_mm = fem.solve_mm(Eigen::VectorXd::Zero(prescribed.size()), prescribed);
  return out;
}

int alpha(const ProxyResampler& r, int x, int y, int z) {
  return r.texels()[4 * ((static_cast<std::size_t>(z) * kN + y) * kN + x) + 3];
}

TEST(IncisionRender, TheOpenedCutIsAnEmptyGapOfItsWidthWithTheCutsMaterialOnBothSides) {
  const DenseVolume volume = ramp();
  const OpenedCut opened = open_cut(kWidth);
  ProxyResampler resampler(volume);
  resampler.set_mesh(opened.incised.mesh);
  resampler.update(opened.displacement_mm);
  const int at_cut = static_cast<int>(std::lround(255 * (0.2 + 0.6 * kCutY / (kN - 1.0))));
  int lines = 0;
  // Lines along y through the opened part (the cut reaches down to z = 20).
  for (const int z : {30, 38, 46}) {
    for (const int x : {3, 17, 24, 40}) {
      ++lines;
      int empty = 0, first_empty = -1, last_empty = -1;
      for (int y = 0; y < kN; ++y) {
        if (alpha(resampler, x, y, z) != 0) continue;
        ++empty;
        if (first_empty < 0) first_empty = y;
        last_empty = y;
      }
      SCOPED_TRACE("line x " + std::to_string(x) + " z " + std::to_string(z));
      if (x == 24 && z == 38) {
        std::printf("[ measured ] gap of %d voxels at y %d..%d; beside it %d | %d (cut: %d):",
                    empty, first_empty, last_empty, alpha(resampler, x, first_empty - 1, z),
                    alpha(resampler, x, last_empty + 1, z), at_cut);
        for (int y = 18; y < 38; ++y) std::printf(" %d", alpha(resampler, x, y, z));
        std::printf("\n");
      }
      // One gap of the width (voxel centres inside [27.4 - 3, 27.4 + 3]: six), +-1 voxel.
      EXPECT_NEAR(empty, kWidth, 1.0);
      EXPECT_EQ(last_empty - first_empty + 1, empty) << "the gap is in one piece";
      EXPECT_NEAR(0.5 * (first_empty + last_empty), kCutY, 1.0) << "centred on the cut";
      // Either side's voxel next to the gap shows the material that was at the cut (the ramp
      // moves 3.3 levels a voxel): continuous with what it was joined to, nothing smeared.
      EXPECT_NEAR(alpha(resampler, x, first_empty - 1, z), at_cut, 4);
      EXPECT_NEAR(alpha(resampler, x, last_empty + 1, z), at_cut, 4);
      // And each side is continuous: no step along the line but the gap.
      for (int y = 1; y < kN; ++y) {
        if (y >= first_empty && y <= last_empty + 1) continue;
        EXPECT_LE(std::abs(alpha(resampler, x, y, z) - alpha(resampler, x, y - 1, z)), 6) << y;
      }
    }
  }
  EXPECT_EQ(lines, 12);
  // Below the cut's end the body is whole: no empty voxel on a line at z = 8.
  for (int y = 0; y < kN; ++y) EXPECT_NE(alpha(resampler, 24, y, 8), 0) << y;
}

TEST(IncisionRender, TheGapFollowsTheWidth) {
  const DenseVolume volume = ramp();
  for (const double width : {2.0, 4.0, 9.0}) {
    const OpenedCut opened = open_cut(width);
    ProxyResampler resampler(volume);
    resampler.set_mesh(opened.incised.mesh);
    resampler.update(opened.displacement_mm);
    int empty = 0;
    for (int y = 0; y < kN; ++y) empty += alpha(resampler, 24, y, 40) == 0;
    EXPECT_NEAR(empty, width, 1.0) << "width " << width;
  }
}

}  // namespace
}  // namespace hapvox::render
