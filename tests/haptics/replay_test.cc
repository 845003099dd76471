#include "haptics/replay.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>

#include "engine/volume_io.h"
#include "haptics/session.h"
#include "test_data.h"

namespace hapvox::haptics {
namespace {

engine::ToolForceOptions small_tool() {
  engine::ToolForceOptions o;
  o.tool.diameter_mm = 8.0;
  return o;
}

TraceDevice press_device(double seconds_hold = 0.2) {
  TraceMakeOptions make;
  make.shape = TraceShape::kPressRelease;
  make.start_mm = Vec3d(32.2, 31.7, 45.0);  // block face at z = 31.5
  make.travel_mm = 16.0;
  make.speed_mm_s = 20.0;
  make.hold_s = seconds_hold;
  return TraceDevice(resample(make_trace(make)), DeviceTransform{});
}

TEST(Replay, SafeForceClampsRampsAndZeroesNonFinite) {
  DeviceLimits limits;
  limits.max_force_n = 2.0;
  bool clamped = false;
  bool nonfinite = false;
  const Vec3d big(3.0, 4.0, 0.0);
  Vec3d f = safe_force(big, 1.0, limits, &clamped, &nonfinite);
  EXPECT_TRUE(clamped);
  EXPECT_NEAR(f.norm(), 2.0, 1e-12);
  EXPECT_NEAR(f.normalized().dot(big.normalized()), 1.0, 1e-12);  // direction kept
  f = safe_force(big, 0.25, limits, &clamped, &nonfinite);
  EXPECT_FALSE(clamped);
  EXPECT_EQ(f, 0.25 * big);
  f = safe_force(Vec3d(NAN, 0, 0), 1.0, limits, &clamped, &nonfinite);
  EXPECT_TRUE(nonfinite);
  EXPECT_EQ(f, Vec3d::Zero());
  f = safe_force(Vec3d(INFINITY, 0, 0), 1.0, limits, &clamped, &nonfinite);
  EXPECT_TRUE(nonfinite);
  EXPECT_EQ(f, Vec3d::Zero());
}

TEST(Replay, ForcesAreFiniteClampedAndRampedIn) {
  const engine::DensityField field = engine::generate_volume("block:dims=64");
  const engine::ToolForceModel model(field, small_tool());
  DeviceLimits limits;
  limits.max_force_n = 1.5;
  limits.ramp_in_s = 0.05;
  // Start already pressed into the block: the ramp must hold the force back.
  TraceMakeOptions make;
  make.shape = TraceShape::kPress;
  make.start_mm = Vec3d(32.2, 31.7, 31.5 + 4.0 + 1.0);
  make.travel_mm = 6.0;  // 5 mm deep: past the clamp
  make.speed_mm_s = 30.0;
  make.hold_s = 0.2;
  const TraceDevice device(resample(make_trace(make)), DeviceTransform{});
  const std::string path = testing::scratch_dir() + "/s.h5";
  SessionWriter session(path);
  const ReplaySummary summary = replay_lockstep(model, device, limits, &session);
  session.close();
  const auto force = read_session_column(path, "/force_n");
  const auto time = read_session_column(path, "/time_s");
  ASSERT_EQ(force.size(), 3 * time.size());
  for (std::size_t i = 0; i < time.size(); ++i) {
    const Vec3d f(force[3 * i], force[3 * i + 1], force[3 * i + 2]);
    ASSERT_TRUE(f.allFinite());
    ASSERT_LE(f.norm(), 1.5 + 1e-12);
    if (time[i] - time[0] < 0.05) {
      EXPECT_LE(f.norm(), 1.5 * (time[i] - time[0]) / 0.05 + 1e-12) << i;
    }
  }
  EXPECT_GT(summary.clamped_ticks, 0u);
  EXPECT_NEAR(summary.peak_force_n, 1.5, 1e-12);
}

TEST(Replay, RepeatedReplaysAreBitIdentical) {
  const engine::DensityField field = engine::generate_volume("block:dims=64");
  const engine::ToolForceModel model(field, small_tool());
  const TraceDevice device = press_device();
  const std::string dir = testing::scratch_dir();
  for (const char* name : {"/a.h5", "/b.h5"}) {
    SessionWriter session(dir + name);
    replay_lockstep(model, device, DeviceLimits{}, &session);
    session.close();
  }
  const SessionInfo info = read_session_info(dir + "/a.h5");
  EXPECT_TRUE(info.complete);
  int compared = 0;
  for (const std::string& dataset : info.datasets) {
    if (dataset.rfind("/timing/", 0) == 0) continue;  // wall-clock: differs by design
    const auto a = read_session_column(dir + "/a.h5", dataset);
    const auto b = read_session_column(dir + "/b.h5", dataset);
    ASSERT_EQ(a.size(), b.size()) << dataset;
    EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(double))) << dataset;
    ++compared;
  }
  EXPECT_GE(compared, 9);
  // And the press did touch: some force was felt.
  const auto contact = read_session_column(dir + "/a.h5", "/contact");
  EXPECT_GT(std::count(contact.begin(), contact.end(), 1.0), 100);
}

TEST(Replay, SessionIsWrittenIncrementallyAndOnlyRenamedWhenComplete) {
  const engine::DensityField field = engine::generate_volume("block:dims=64");
  const engine::ToolForceModel model(field, small_tool());
  const TraceDevice device = press_device();
  const std::string path = testing::scratch_dir() + "/s.h5";
  {
    SessionWriter session(path, 250);
    replay_lockstep(model, device, DeviceLimits{}, &session);
    // Dropped without close(), as if the process died: the flushed rows survive in
    // PATH.partial and nothing appears at PATH.
  }
  EXPECT_FALSE(std::filesystem::exists(path));
  ASSERT_TRUE(std::filesystem::exists(path + ".partial"));
  const SessionInfo info = read_session_info(path + ".partial");
  EXPECT_FALSE(info.complete);
  EXPECT_EQ(info.rows, device.tick_count());  // the destructor flushed the tail
}

TEST(Replay, ZeroForceWhileTheTraceNeverTouches) {
  const engine::DensityField field = engine::generate_volume("block:dims=64");
  const engine::ToolForceModel model(field, small_tool());
  TraceMakeOptions make;
  make.shape = TraceShape::kCircle;
  make.start_mm = Vec3d(30, 30, 50);
  make.travel_mm = 2.0;
  const TraceDevice device(resample(make_trace(make)), DeviceTransform{});
  const ReplaySummary summary = replay_lockstep(model, device, DeviceLimits{}, nullptr);
  EXPECT_EQ(summary.contact_ticks, 0u);
  EXPECT_EQ(summary.peak_force_n, 0.0);
}

TEST(Replay, PercentileByNearestRank) {
  EXPECT_EQ(percentile({}, 50), 0.0);
  EXPECT_EQ(percentile({5, 1, 3, 2, 4}, 50), 3.0);
  EXPECT_EQ(percentile({5, 1, 3, 2, 4}, 100), 5.0);
  EXPECT_EQ(percentile({5, 1, 3, 2, 4}, 0), 1.0);
}

}  // namespace
}  // namespace hapvox::haptics

namespace hapvox::haptics {
namespace {

struct SculptRun {
  ReplaySummary summary;
  SculptSummary sculpt;
  std::vector<std::int64_t> mass_per_tick;
};

// A press-and-stroke into clay with plasticity, deletion and relaxation in lockstep.
SculptRun sculpt_block(const std::string& session_path, engine::DensityField* out_field = nullptr,
                       std::unique_ptr<engine::MassGrid>* out_mass = nullptr) {
  engine::DensityField field = engine::generate_volume("block:dims=64");  // face z = 31.5
  engine::ToolForceOptions options;
  options.tool.diameter_mm = 10.0;
  options.plastic.enabled = true;
  options.plastic.yield_stress_pa = 8e3;  // mean contact pressure at which the clay flows
  const engine::ToolForceModel model(field, options);
  auto mass = std::make_unique<engine::MassGrid>(field);
  SurfaceChangeChannel channel;
  SculptContext context;
  context.mass = mass.get();
  context.mirror = &field;
  context.channel = &channel;
  context.mass_every_ticks = 1;
  TraceMakeOptions make;
  make.shape = TraceShape::kStroke;
  make.start_mm = Vec3d(20.3, 31.6, 40.0);
  make.travel_mm = 6.0;  // tool bottom 2.5 mm below the face (z = 31.5), top 7.5 mm above
  make.speed_mm_s = 10.0;
  make.stroke_length_mm = 24.0;
  const TraceDevice device(resample(make_trace(make)), DeviceTransform{});
  SculptRun run;
  SessionWriter session(session_path);
  run.summary = replay_lockstep(model, device, DeviceLimits{}, &session, {}, &context, &run.sculpt);
  session.close();
  for (double m : read_session_column(session_path, "/relax/total_mass_units")) {
    run.mass_per_tick.push_back(static_cast<std::int64_t>(m));
  }
  if (out_mass != nullptr) *out_mass = std::move(mass);
  if (out_field != nullptr) *out_field = field;
  return run;
}

TEST(Sculpt, MassIsExactThroughALongSculptingReplay) {
  const std::string dir = testing::scratch_dir();
  const SculptRun run = sculpt_block(dir + "/s.h5");
  EXPECT_GT(run.sculpt.plastic_events, 1000u);
  EXPECT_GT(run.sculpt.deleted_voxels, 100u);
  EXPECT_GT(run.sculpt.relaxed_voxels, 1000u);
  EXPECT_EQ(run.sculpt.final_mass_units, run.sculpt.initial_mass_units);
  EXPECT_EQ(run.sculpt.initial_mass_units, 64ll * 64 * 32 * engine::kNormalDensityUnits);
  for (std::int64_t m : run.mass_per_tick) ASSERT_EQ(m, run.sculpt.initial_mass_units);
  // Plastic events are recorded tick by tick.
  const auto events = read_session_column(dir + "/s.h5", "/plastic/event");
  EXPECT_EQ(static_cast<std::uint64_t>(std::count(events.begin(), events.end(), 1.0)),
            run.sculpt.plastic_events);
}

TEST(Sculpt, LeavesAGrooveThatSettlesAndIsFeltAsAPermanentDent) {
  const std::string dir = testing::scratch_dir();
  engine::DensityField field = engine::generate_volume("block:dims=8");
  std::unique_ptr<engine::MassGrid> mass;
  sculpt_block(dir + "/s.h5", &field, &mass);
  for (int round = 0; round < 200 && !mass->settled(); ++round) mass->relax(100000);
  EXPECT_TRUE(mass->settled());
  mass->publish_changes(field);
  // Hole under the tool's path: empty at the groove's centre line, 1 mm below the face.
  auto acc = field.grid().getConstAccessor();
  for (int x = 32; x <= 40; x += 4) EXPECT_LT(acc.getValue(openvdb::Coord(x, 32, 30)), 0.05f) << x;
  // Far from the groove the block is untouched.
  EXPECT_NEAR(acc.getValue(openvdb::Coord(5, 5, 10)), 1.0f, 0.021f);
  // An elastic probe now touches down deeper in the groove than on the flat.
  engine::ToolForceOptions probe;
  probe.tool.diameter_mm = 2.0;
  const engine::ToolForceModel model(field, probe);
  auto touch_height = [&](double x, double y) {
    engine::ToolForceState state = model.make_state();
    for (double z = 45.0; z > 0.0; z -= 0.01) {
      model.step(Vec3d(x, y, z), state);
      if (state.in_contact) return z;
    }
    return 0.0;
  };
  const double flat = touch_height(10.0, 10.0);
  EXPECT_NEAR(flat, 31.5 + 1.0, 0.02);  // face (the nominal surface) + probe radius
  EXPECT_LT(touch_height(36.0, 31.6), flat - 0.9);
}

TEST(Sculpt, LockstepSculptingIsBitIdentical) {
  const std::string dir = testing::scratch_dir();
  sculpt_block(dir + "/a.h5");
  sculpt_block(dir + "/b.h5");
  for (const std::string& dataset : read_session_info(dir + "/a.h5").datasets) {
    if (dataset.rfind("/timing/", 0) == 0) continue;
    const auto a = read_session_column(dir + "/a.h5", dataset);
    const auto b = read_session_column(dir + "/b.h5", dataset);
    ASSERT_EQ(a.size(), b.size()) << dataset;
    EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(double))) << dataset;
  }
}

// The relaxation stage (lockstep tick or realtime slice) does bounded work: at most
// max_deletions queued changes, the rest left in the channel for the next stage, then at
// most the relaxation budget; draining at the end applies the rest and lands every flow.
TEST(Sculpt, RelaxStageAppliesAtMostItsDeletionsAndRelaxesWithinItsBudget) {
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
    EXPECT_EQ(work.relax_steps, (mass.work().relaxed_voxels - was.relaxed_voxels) +
                                    (mass.work().flow_visits - was.flow_visits));
    EXPECT_EQ(mass.total_mass_units(), before);
  }
  EXPECT_EQ(deletions, (std::vector<std::size_t>{8, 8, 4, 0}));
  drain_relaxation(mass, channel);
  EXPECT_EQ(mass.flowing_units(), 0);
  EXPECT_EQ(mass.total_mass_units(), before);
}

TEST(SurfaceChannel, OverflowCoalescesIntoOneSweepAndLosesNothing) {
  SurfaceChangeChannel channel;
  engine::SurfaceChange change;
  change.direction = Vec3d(0, 0, -1);
  change.radius_mm = 2.0;
  const unsigned extra = 10;
  for (unsigned i = 0; i < SurfaceChangeChannel::kCapacity + extra; ++i) {
    change.from_mm = change.position_mm = Vec3d(0, 0, -0.01 * i);
    channel.push(change);
  }
  EXPECT_EQ(channel.overflows(), extra);
  EXPECT_TRUE(channel.has_pending());
  engine::SurfaceChange got;
  unsigned popped = 0;
  while (channel.pop(got)) ++popped;
  EXPECT_EQ(popped, SurfaceChangeChannel::kCapacity);
  ASSERT_TRUE(channel.flush());
  ASSERT_TRUE(channel.pop(got));
  // The coalesced change sweeps from the first overflowed position to the last one.
  EXPECT_EQ(got.from_mm.z(), -0.01 * SurfaceChangeChannel::kCapacity);
  EXPECT_EQ(got.position_mm.z(), -0.01 * (SurfaceChangeChannel::kCapacity + extra - 1));
  EXPECT_FALSE(channel.pop(got));
}

}  // namespace
}  // namespace hapvox::haptics
