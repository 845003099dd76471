#include "haptics/voxel_model.h"

#include <gtest/gtest.h>

#include <vector>

#include "engine/volume_io.h"

namespace hapvox::haptics {
namespace {

// The relaxation stage (lockstep tick or realtime slice) does bounded work: at most
// max_deletions queued changes, the rest left in the channel for the next stage, then at
// most the relaxation budget; draining at the end applies the rest and lands every flow.
TEST(VoxelModel, RelaxStageAppliesAtMostItsDeletionsAndRelaxesWithinItsBudget) {
  engine::MassGrid mass(engine::generate_volume("block:dims=48"));  // face at z = 23.5
  const std::int64_t before = mass.total_mass_units();
  SurfaceChangeChannel channel;
  engine::SurfaceChange change;
  change.direction = Vec3d(0, 0, -1);
  change.radius_mm = 4.0;
  for (int i = 0; i < 20; ++i) {
    change.from_mm = change.position_mm = Vec3d(14.0 + i, 24.0, 24.0);
    ASSERT_TRUE(channel.push(change));
  }
  std::vector<std::size_t> deletions;
  for (int stage = 0; stage < 4; ++stage) {
    const engine::RelaxWork was = mass.work();
    const RelaxStageWork work = run_relax_stage(mass, channel, 8, 50);
    deletions.push_back(work.deletions);
    EXPECT_LE(mass.work().relaxed_voxels - was.relaxed_voxels, 50u);
    EXPECT_LE(mass.work().flow_visits - was.flow_visits,
              50u * engine::RelaxOptions{}.flow_visits_per_voxel);
    EXPECT_LE(mass.work().stale_pops - was.stale_pops, 50u * engine::MassGrid::kStalePopsPerVoxel);
    EXPECT_EQ(work.relax_steps, (mass.work().relaxed_voxels - was.relaxed_voxels) +
                                    (mass.work().flow_visits - was.flow_visits) +
                                    (mass.work().stale_pops - was.stale_pops));
    EXPECT_EQ(mass.total_mass_units(), before);
  }
  EXPECT_EQ(deletions, (std::vector<std::size_t>{8, 8, 4, 0}));
  drain_relaxation(mass, channel);
  EXPECT_EQ(mass.flowing_units(), 0);
  EXPECT_EQ(mass.total_mass_units(), before);
}

}  // namespace
}  // namespace hapvox::haptics
