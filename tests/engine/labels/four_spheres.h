#pragma once
// The `four-spheres` phantom as engine/volume_io.h documents it, stated independently of the
// generator: four spheres of radius 0.18 n on a regular tetrahedron around the box centre
// c = (n - 1) / 2, centres offset by d = 0.3 n / sqrt(3) per axis, densities 0.4 / 0.6 /
// 0.8 / 1.0, in index space (world = index * voxel_mm, origin 0).

#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <string>

#include "engine/density_field.h"

namespace hapvox::testing {

struct FourSpheres {
  int n = 64;
  double voxel_mm = 1.0;

  double radius() const { return 0.18 * n; }  // index units
  engine::Vec3d centre(int sphere) const {
    const double c = 0.5 * (n - 1);
    const double d = 0.3 * n / std::sqrt(3.0);
    static constexpr std::array<std::array<int, 3>, 4> kSigns = {
        {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}}};
    const auto& s = kSigns[static_cast<std::size_t>(sphere)];
    return engine::Vec3d(c + s[0] * d, c + s[1] * d, c + s[2] * d);
  }
  engine::Vec3d centre_mm(int sphere) const { return centre(sphere) * voxel_mm; }
  static float density(int sphere) { return 0.4f + 0.2f * static_cast<float>(sphere); }
  bool inside(int sphere, const engine::Vec3i& ijk) const {
    return (ijk.cast<double>() - centre(sphere)).squaredNorm() <= radius() * radius();
  }
  /// Voxel centres inside the sphere, counted directly.
  std::int64_t lattice_count(int sphere) const {
    std::int64_t count = 0;
    for (int z = 0; z < n; ++z) {
      for (int y = 0; y < n; ++y) {
        for (int x = 0; x < n; ++x) count += inside(sphere, engine::Vec3i(x, y, z)) ? 1 : 0;
      }
    }
    return count;
  }
  /// 4/3 pi r^3 in voxels.
  double analytic_voxels() const { return 4.0 / 3.0 * std::numbers::pi * std::pow(radius(), 3); }
  std::string spec() const {
    return "four-spheres:dims=" + std::to_string(n) + ",voxel_mm=" + std::to_string(voxel_mm);
  }
};

}  // namespace hapvox::testing
