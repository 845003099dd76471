// The default contact law against contact mechanics: Hertz for a rigid sphere on an
// elastic half-space, independence of the voxel size and plastic unloading
// (docs/physics.md, "Contact law"; friction and yield: contact_laws_test.cc).

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "engine/block_field.h"
#include "engine/tool_force.h"

namespace hapvox::engine {
namespace {

// A block of voxel size h_mm with room above its face.
DensityField make_block(int n, int top_k, double h_mm) {
  return fixtures::make_block(n, top_k, Vec3d::Constant(h_mm), top_k + 8);
}

// Hertz: F = 4/3 E* sqrt(R) d^1.5, E* = E / (1 - nu^2) (rigid sphere, elastic half-space).
double hertz_force_n(double e_pa, double nu, double radius_mm, double depth_mm) {
  const double e_star = e_pa / (1.0 - nu * nu);
  return 4.0 / 3.0 * e_star * std::sqrt(radius_mm) * std::pow(depth_mm, 1.5) * 1e-6;
}

struct PressPoint {
  double depth_mm;
  double force_n;
};

// A slow vertical press (2 um a tick) of a sphere of radius r_mm into a block of voxel
// size h_mm, at an xy off the voxel lattice; returns (depth below the nominal surface,
// F_z) for every tick deeper than one voxel down to max_depth_mm.
std::vector<PressPoint> press(double r_mm, double h_mm, double nu, double max_depth_mm,
                              double e_pa = 100e3) {
  const double footprint_mm = 2.0 * std::sqrt(2.0 * r_mm * max_depth_mm) + 4.0 * h_mm + 2.0;
  const int n = static_cast<int>(std::ceil(footprint_mm / h_mm)) + 2;
  const int top_k = static_cast<int>(std::ceil((max_depth_mm + 2.0) / h_mm)) + 2;
  const DensityField field = make_block(n, top_k, h_mm);
  ToolForceOptions options;
  options.tool.diameter_mm = 2.0 * r_mm;
  options.material.youngs_modulus_pa = e_pa;
  options.material.poisson_ratio = nu;
  const ToolForceModel model(field, options);
  ToolForceState state = model.make_state();
  const double face_z = (top_k - 0.5) * h_mm;
  const Vec3d xy(0.5 * (n - 1) * h_mm + 0.37 * h_mm, 0.5 * (n - 1) * h_mm - 0.21 * h_mm, 0.0);
  std::vector<PressPoint> points;
  for (double depth = -h_mm; depth <= max_depth_mm; depth += 0.002) {
    model.step(xy + Vec3d(0, 0, face_z + r_mm - depth), state);
    if (depth >= h_mm) points.push_back({depth, state.force_n.z()});
  }
  return points;
}

double log_log_slope(const std::vector<PressPoint>& points) {
  double mx = 0, my = 0;
  for (const PressPoint& p : points) mx += std::log(p.depth_mm), my += std::log(p.force_n);
  mx /= points.size();
  my /= points.size();
  double sxy = 0, sxx = 0;
  for (const PressPoint& p : points) {
    const double dx = std::log(p.depth_mm) - mx;
    sxy += dx * (std::log(p.force_n) - my);
    sxx += dx * dx;
  }
  return sxy / sxx;
}

TEST(ContactLaw, HertzWithinFivePercentWithSlopeOneAndAHalf) {
  int cases = 0;
  for (double r : {2.0, 4.0, 8.0}) {
    for (double nu : {0.0, 0.3, 0.45, 0.49}) {
      for (double h : {0.25, 0.5, 1.0}) {
        // d / R in [0.02, 0.15], and at least one voxel deep.
        const double lo = std::max(0.02 * r, h);
        const double hi = 0.15 * r;
        if (lo >= hi) continue;
        std::vector<PressPoint> in_range;
        for (const PressPoint& p : press(r, h, nu, hi)) {
          if (p.depth_mm < lo) continue;
          const double expected = hertz_force_n(100e3, nu, r, p.depth_mm);
          ASSERT_NEAR(p.force_n, expected, 0.05 * expected)
              << "R " << r << " nu " << nu << " h " << h << " d " << p.depth_mm;
          in_range.push_back(p);
        }
        ASSERT_GT(in_range.size(), 20u);
        EXPECT_NEAR(log_log_slope(in_range), 1.5, 0.05) << "R " << r << " nu " << nu << " h " << h;
        ++cases;
      }
    }
  }
  EXPECT_EQ(cases, 4 * 6);  // R = 2: h = 0.25; R = 4: 0.25, 0.5; R = 8: all three
}

// Force at the tick whose depth is nearest depth_mm.
double force_at(const std::vector<PressPoint>& points, double depth_mm) {
  const PressPoint* best = &points.front();
  for (const PressPoint& p : points) {
    if (std::abs(p.depth_mm - depth_mm) < std::abs(best->depth_mm - depth_mm)) best = &p;
  }
  EXPECT_LT(std::abs(best->depth_mm - depth_mm), 0.002);
  return best->force_n;
}

TEST(ContactLaw, ForceAtEqualIndentationDoesNotDependOnTheVoxelSize) {
  const std::vector<PressPoint> coarse = press(8.0, 1.0, 0.3, 3.0);
  const std::vector<PressPoint> medium = press(8.0, 0.5, 0.3, 3.0);
  const std::vector<PressPoint> fine = press(8.0, 0.25, 0.3, 3.0);
  for (double depth : {1.0, 1.5, 2.0, 2.5, 3.0}) {
    const double f_fine = force_at(fine, depth);
    EXPECT_NEAR(force_at(coarse, depth), f_fine, 0.05 * f_fine) << depth;
    EXPECT_NEAR(force_at(medium, depth), f_fine, 0.05 * f_fine) << depth;
  }
}

TEST(ContactLaw, ForceGrowsWithToolSizeAndPoissonRatioAsHertzSays) {
  // Same indentation, other tool or material: the ratios Hertz predicts (sqrt(R) and
  // 1 / (1 - nu^2)), where the paper's law gave the same force for every R and x12.7
  // from nu = 0.3 to 0.49.
  const double depth = 0.5;
  const double f_r2 = force_at(press(2.0, 0.25, 0.3, depth + 0.01), depth);
  const double f_r8 = force_at(press(8.0, 0.25, 0.3, depth + 0.01), depth);
  EXPECT_NEAR(f_r8 / f_r2, 2.0, 0.1);
  const double f_nu49 = force_at(press(8.0, 0.25, 0.49, depth + 0.01), depth);
  EXPECT_NEAR(f_nu49 / f_r8, (1.0 - 0.09) / (1.0 - 0.49 * 0.49), 0.02);
}

TEST(ContactLaw, PlasticUnloadingIsElasticAndNeverPullsTheToolIn) {
  const double h = 0.5;
  const DensityField field = make_block(48, 24, h);
  ToolForceOptions options;
  options.tool.diameter_mm = 8.0;
  options.plastic.enabled = true;
  options.plastic.yield_stress_pa = 10e3;  // perfectly plastic
  const ToolForceModel model(field, options);
  ToolForceState state = model.make_state();
  const double top = 23.5 * h + 4.0;
  std::uint64_t steps_at_turn = 0;
  double z_turn = top + 0.5;
  for (; z_turn > top - 2.0; z_turn -= 0.002) model.step(Vec3d(12, 12, z_turn), state);
  steps_at_turn = state.plastic_steps;
  ASSERT_GT(steps_at_turn, 100u);
  const double force_at_turn = state.force_n.z();
  double last_force = force_at_turn;
  bool released = false;
  for (double z = z_turn + 0.004; z < top + 1.0; z += 0.002) {
    model.step(Vec3d(12, 12, z), state);
    ASSERT_FALSE(state.surface_change_emitted) << z;
    ASSERT_GE(state.force_n.z(), 0.0) << z;                 // never into the material
    ASSERT_LE(state.force_n.z(), last_force + 1e-12) << z;  // unloads monotonically
    last_force = state.force_n.z();
    released = released || state.force_n.z() == 0.0;
  }
  EXPECT_EQ(state.plastic_steps, steps_at_turn);
  EXPECT_TRUE(released);
}

}  // namespace
}  // namespace hapvox::engine
