// The co-rotational grab held still (issue 30, point 0): the audit's block, pulled 6, 10
// and 20 mm and pushed 10 mm, each held 2 s, with a stiff and a soft coupling. Before each
// FEM step solved its equilibrium (one stiffness-warping pass a step), the 10 mm pull
// flipped sign every step and grew x1.7 a step once the device stopped, and the push
// diverged.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "engine/labels/materials.h"
#include "engine/proxy/label_source.h"
#include "engine/proxy/proxy_mesh.h"
#include "fem_fixtures.h"
#include "haptics/fem_model.h"
#include "haptics/replay.h"

namespace hapvox::haptics {
namespace corotational_grab {  // its own names in the unity build
namespace {

// block:dims=40,fill=1 of 1 mm voxels: the clay at E = 100 kPa, nu = 0.45, its bottom
// quarter fixed; the grab's tool 12 mm across at the top face's centre.
constexpr int kBlockVoxels = 40;
constexpr double kTopMm = kBlockVoxels - 0.5;
constexpr double kCentreMm = 0.5 * (kBlockVoxels - 1);
constexpr double kToolRadiusMm = 6.0;
constexpr std::size_t kMoveTicks = 500;   // the device's move, at 1 kHz
constexpr std::size_t kHoldTicks = 2000;  // then held still for 2 s
constexpr std::size_t kFemEveryTicks = 10;

constexpr const char* kClay = R"(
[[material]]
label = 0
name = "air"
youngs_modulus_pa = 1e3
poisson_ratio = 0.3

[[material]]
label = 1
name = "clay"
youngs_modulus_pa = 100e3
poisson_ratio = 0.45
intensity = [0.5, 1.0]

[[fixed_region]]
label = 1
side = "-z"
fraction = 0.25
)";

struct GrabCase {
  double move_z_mm;  // + pulls up, - pushes down
  double coupling_n_per_mm;
};

void PrintTo(const GrabCase& c, std::ostream* out) {
  *out << (c.move_z_mm > 0 ? "pull " : "push ") << std::abs(c.move_z_mm) << " mm at "
       << c.coupling_n_per_mm << " N/mm";
}

const FemModel& audit_block_model(double coupling_n_per_mm) {
  static const engine::labels::Materials clay = engine::labels::parse_materials(kClay, "test");
  static const engine::proxy::ProxyMesh proxy = [] {
    engine::proxy::ProxyMeshOptions mesh;
    return engine::proxy::build_proxy_mesh(
        engine::proxy::proxy_labels(engine::labels::read_scalar_volume("block:dims=40,fill=1"),
                                    clay, {}),
        clay, mesh);
  }();
  FemOptions o;
  o.interaction = FemInteraction::kGrab;
  o.solver = FemSolver::kCorotational;
  o.tool_radius_mm = kToolRadiusMm;
  o.coupling_n_per_mm = coupling_n_per_mm;
  o.fem_every_ticks = kFemEveryTicks;
  static std::vector<std::unique_ptr<FemModel>> models;
  models.push_back(std::make_unique<FemModel>(proxy, o));
  return *models.back();
}

struct Hold {
  std::vector<Vec3d> force_n;      // each tick's
  std::vector<Vec3d> centroid_mm;  // the captured vertices' mean displacement, each FEM step
  Vec3d proxy_offset_mm;           // the proxy's offset from where it grabbed, at the end
  Vec3d device_offset_mm;
  engine::fem::EquilibriumReport last;
  std::uint64_t unconverged = 0;        // FEM steps short of the tolerance, the move's too
  std::size_t unconverged_in_hold = 0;  // of the hold's steps after its first 10
  std::size_t captured = 0;
};

Hold grab_and_hold(const GrabCase& c) {
  const FemModel& model = audit_block_model(c.coupling_n_per_mm);
  const Vec3d start(kCentreMm, kCentreMm, kTopMm);
  TraceDevice device = fem_fixtures::device_along(kMoveTicks + kHoldTicks, [&](std::size_t k) {
    return Vec3d(start +
                 Vec3d(0, 0, std::min(1.0, static_cast<double>(k) / kMoveTicks) * c.move_z_mm));
  });
  auto handoff = std::make_unique<FemHandoff>();
  FemForceStage force(model, *handoff);
  FemBackgroundStage fem(model, *handoff, device.tool_position_mm(0));
  fem.begin();
  const DeviceLimits limits = fem_fixtures::no_ramp();
  ForceSafety safety(limits, device.rate_hz());
  Hold hold;
  hold.captured = fem.captured_vertices().size();
  std::uint64_t steps = fem.steps();
  for (std::size_t k = 0; k < device.tick_count(); ++k) {
    TickRecord row;
    run_force_stage(force, device, k, limits, safety, row);
    fem.run_lockstep_tick(k, row, nullptr);
    hold.force_n.push_back(row.force_n);
    hold.proxy_offset_mm = row.tool_position_mm + row.displacement_mm - start;
    hold.device_offset_mm = row.tool_position_mm - start;
    if (fem.steps() != steps) {
      steps = fem.steps();
      Vec3d sum = Vec3d::Zero();
      for (const std::int32_t v : fem.captured_vertices()) {
        sum += fem.displacement_mm().segment<3>(3 * v);
      }
      hold.centroid_mm.push_back(sum / static_cast<double>(fem.captured_vertices().size()));
      if (k >= kMoveTicks + 10 * kFemEveryTicks && !fem.last_equilibrium().converged) {
        ++hold.unconverged_in_hold;
      }
    }
  }
  hold.last = fem.last_equilibrium();
  hold.unconverged = fem.unconverged_steps();
  return hold;
}

class CorotationalGrab : public ::testing::TestWithParam<GrabCase> {};

TEST_P(CorotationalGrab, HoldsStillAtItsEquilibrium) {
  const GrabCase c = GetParam();
  const engine::fem::EquilibriumOptions eq;
  const Hold hold = grab_and_hold(c);
  ASSERT_GT(hold.captured, 0u);
  // Every FEM step of the hold reached its equilibrium, the last one too, with no tet
  // inverted. (While the device moves, a step may end short of the tolerance and the next
  // goes on from there: the warped tangent leaves out the rotations' change, so its
  // convergence is linear, slow at 20 mm.)
  EXPECT_EQ(hold.unconverged_in_hold, 0u) << hold.unconverged << " in all";
  EXPECT_TRUE(hold.last.converged);
  EXPECT_LE(hold.last.residual_n, eq.residual_tolerance_n);
  EXPECT_EQ(hold.last.inverted_tets, 0);
  const Vec3d f = hold.force_n.back();
  // The force pulls the device back towards where it grabbed, along the move.
  EXPECT_LT(f.z() * c.move_z_mm, 0.0) << f.transpose();
  // The proxy is where the coupling's spring balances the force: F / k_c behind the device.
  EXPECT_NEAR((hold.device_offset_mm - hold.proxy_offset_mm).norm(), f.norm() / c.coupling_n_per_mm,
              1e-6 + 1e-6 * f.norm() / c.coupling_n_per_mm);
  // The captured region is at the proxy (held there: within 0.1 mm).
  EXPECT_LT((hold.centroid_mm.back() - hold.proxy_offset_mm).norm(), 0.1)
      << hold.centroid_mm.back().transpose() << " vs " << hold.proxy_offset_mm.transpose();
  // The sideways force is a small share of the pull and does not grow while held. Not
  // zero: the lattice's Kuhn tets all split their cubes along (1, 1, 1), so the mesh is
  // stiffer one way round the diagonal, and a grab straight up pulls a little along
  // (1, 1, 0) in linear FEM too (5.6 % of the 6 mm pull and of the 10 mm push, on this
  // mesh). The unconverged iteration's sideways force (22 N of an 84 N pull at 20 mm) is
  // what this catches; the issue's 3 % is not met by the 6 mm pull (3.6 %) and the pushes
  // (8.6 % at 1000 N/mm, 3.9 % at 1 N/mm) on this mesh (docs/physics.md).
  const std::size_t hold_start = kMoveTicks + 10 * kFemEveryTicks;
  double sideways_first = 0.0, sideways_last = 0.0;
  for (std::size_t k = hold_start; k < hold.force_n.size(); ++k) {
    const double sideways = hold.force_n[k].head<2>().norm();
    EXPECT_LE(sideways, 0.10 * std::abs(hold.force_n[k].z())) << "tick " << k;
    (k < hold_start + 200 ? sideways_first : sideways_last) = sideways;
  }
  EXPECT_LE(sideways_last, sideways_first + 1e-9);
  // Still: the captured region moves no more while held than the solves' tolerance allows.
  const std::size_t steps = hold.centroid_mm.size();
  EXPECT_LT((hold.centroid_mm[steps - 1] - hold.centroid_mm[steps - 100]).norm(), 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Audit, CorotationalGrab,
                         ::testing::Values(GrabCase{6, 1000}, GrabCase{10, 1000},
                                           GrabCase{20, 1000}, GrabCase{-10, 1000}, GrabCase{6, 1},
                                           GrabCase{10, 1}, GrabCase{20, 1}, GrabCase{-10, 1}),
                         [](const ::testing::TestParamInfo<GrabCase>& info) {
                           const GrabCase& c = info.param;
                           return std::string(c.move_z_mm > 0 ? "Pull" : "Push") +
                                  std::to_string(static_cast<int>(std::abs(c.move_z_mm))) + "mmAt" +
                                  std::to_string(static_cast<int>(c.coupling_n_per_mm)) + "NPerMm";
                         });

}  // namespace
}  // namespace corotational_grab
}  // namespace hapvox::haptics
