#include "haptics/replay.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>

#include "engine/volume_io.h"
#include "haptics/session.h"
#include "haptics/voxel_model.h"
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
  // Clamped, then ramped: a quarter of the clamped force, not the raw one clamped.
  f = safe_force(big, 0.25, limits, &clamped, &nonfinite);
  EXPECT_TRUE(clamped);
  EXPECT_NEAR(f.norm(), 0.25 * 2.0, 1e-12);
  f = safe_force(0.1 * big, 0.25, limits, &clamped, &nonfinite);
  EXPECT_FALSE(clamped);
  EXPECT_EQ(f, 0.25 * (0.1 * big));
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
  TraceDevice device(resample(make_trace(make)), DeviceTransform{});
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

// A press from `start_depth_mm` below the 64^3 block's face (negative: above it) to
// `end_depth_mm`, at 20 mm/s, then held still for `hold_s`: the 8 mm tool's centre sits
// radius - depth above the face at z = 31.5.
TraceDevice press_to_depth(double start_depth_mm, double end_depth_mm, double hold_s) {
  TraceMakeOptions make;
  make.shape = TraceShape::kPress;
  make.start_mm = Vec3d(32.2, 31.7, 31.5 + 4.0 - start_depth_mm);
  make.travel_mm = end_depth_mm - start_depth_mm;
  make.speed_mm_s = 20.0;
  make.hold_s = hold_s;
  return TraceDevice(resample(make_trace(make)), DeviceTransform{});
}

// Issue 8 point 5: a tool already in the material at tick 0 gets no force step. The sent
// force is the unramped force (the same replay with --ramp-in-s 0) times k / (ramp * rate)
// at tick k: zero at the first tick, half at ramp / 2, all of it from the ramp's end on.
TEST(Replay, ToolStartingInContactFeelsTheForceRampInLinearly) {
  const engine::DensityField field = engine::generate_volume("block:dims=64");
  const engine::ToolForceModel model(field, small_tool());
  TraceDevice device = press_to_depth(1.0, 4.0, 0.2);
  const std::string dir = testing::scratch_dir();
  DeviceLimits ramped;
  ramped.ramp_in_s = 0.1;
  DeviceLimits unramped = ramped;
  unramped.ramp_in_s = 0.0;
  for (const auto& [name, limits] : {std::pair{"/ramped.h5", ramped}, {"/unramped.h5", unramped}}) {
    SessionWriter session(dir + name);
    replay_lockstep(model, device, limits, &session);
    session.close();
  }
  const auto contact = read_session_column(dir + "/ramped.h5", "/contact");
  const auto force = read_session_column(dir + "/ramped.h5", "/force_n");
  const auto full = read_session_column(dir + "/unramped.h5", "/force_n");
  ASSERT_EQ(contact[0], 1.0);  // pressed in from the first tick
  const auto at = [](const std::vector<double>& f, std::size_t k) {
    return Vec3d(f[3 * k], f[3 * k + 1], f[3 * k + 2]);
  };
  const std::size_t ramp_ticks = 100;  // 0.1 s at 1 kHz
  EXPECT_EQ(at(force, 0).norm(), 0.0);
  ASSERT_GT(at(full, ramp_ticks / 2).norm(), 0.2);  // the press is felt by then
  EXPECT_NEAR(at(force, ramp_ticks / 2).norm(), 0.5 * at(full, ramp_ticks / 2).norm(), 1e-9);
  for (std::size_t k = 0; k < contact.size(); ++k) {
    const double share = std::min(1.0, static_cast<double>(k) / ramp_ticks);
    ASSERT_LE((at(force, k) - share * at(full, k)).norm(), 1e-12 * (1.0 + at(full, k).norm()))
        << "tick " << k;
  }
  const auto scale = read_session_column(dir + "/ramped.h5", "/force_scale");
  EXPECT_EQ(scale[0], 0.0);
  EXPECT_DOUBLE_EQ(scale[ramp_ticks / 2], 0.5);
  EXPECT_EQ(scale[ramp_ticks], 1.0);
}

// Issue 8 point 4, in the force stage both loops share: after a watchdog trip the force
// falls to zero and rises back at the ramp's slope. With the tool held still in the
// material the model's own force does not change, so every step of the sent force is the
// ramp's: at most |F| / (ramp * rate), never the jump to zero a plain cut would make.
TEST(Replay, AWatchdogTripRampsTheForceDownAndBackWithoutAStep) {
  const engine::DensityField field = engine::generate_volume("block:dims=64");
  const engine::ToolForceModel model(field, small_tool());
  TraceDevice device = press_to_depth(-1.0, 1.0, 1.0);  // pressed and held from 0.1 s
  const DeviceLimits limits;                            // 10 N, 0.1 s ramp
  VoxelForceStage stage(model);
  ForceSafety safety(limits, device.rate_hz());
  ForceRamp& ramp = safety.ramp;
  EXPECT_DOUBLE_EQ(ramp.step(), 0.01);
  const std::size_t trip = 600, steps = 100;
  std::vector<Vec3d> sent, model_force;  // model_force: clamped, not ramped
  std::vector<double> scale;
  for (std::size_t tick = 0; tick < device.tick_count(); ++tick) {
    TickRecord row;
    run_force_stage(stage, device, tick, limits, safety, row);
    sent.push_back(row.force_n);
    scale.push_back(row.force_scale);
    bool clamped = false, nonfinite = false;
    model_force.push_back(safe_force(stage.state().force_n, 1.0, limits, &clamped, &nonfinite));
    if (tick == trip) ramp.trip();  // as the realtime loop does after an overrun
  }
  ASSERT_GT(sent.size(), trip + 2 * steps + 10);
  const Vec3d held = model_force[trip];
  ASSERT_GT(held.norm(), 0.2);
  // The tripping tick sends its own force; then down to zero and back, one step a tick.
  EXPECT_EQ(sent[trip], held);
  for (std::size_t k = 1; k <= steps; ++k) {
    ASSERT_NEAR(scale[trip + k], 1.0 - 0.01 * k, 1e-12) << k;
    ASSERT_NEAR(scale[trip + steps + k], 0.01 * k, 1e-12) << k;
  }
  EXPECT_EQ(sent[trip + steps], Vec3d::Zero());
  EXPECT_EQ(sent[trip + 2 * steps], held);
  EXPECT_EQ(ramp.trips(), 1u);
  EXPECT_EQ(ramp.reduced_ticks(), 2 * steps - 1);
  // The bound, on every tick of the run: the ramp's step of the device maximum plus the
  // model's own change. Around the trip the model is still, and the steps are the ramp's.
  double largest = 0.0;
  for (std::size_t k = 1; k < sent.size(); ++k) {
    const double step = (sent[k] - sent[k - 1]).norm();
    ASSERT_LE(step, limits.max_force_n * ramp.step() +
                        (model_force[k] - model_force[k - 1]).norm() + 1e-12)
        << "tick " << k;
    if (k > trip - 50 && k < trip + 2 * steps + 50) {
      ASSERT_EQ(model_force[k], held) << k;
      largest = std::max(largest, step);
    }
  }
  EXPECT_LE(largest, held.norm() * 0.01 + 1e-12);
  EXPECT_GE(largest, held.norm() * 0.01 * 0.999);
}

TEST(Replay, ForceRampRisesFallsOnATripAndTurnsBackOnASecondOne) {
  DeviceLimits limits;
  limits.ramp_in_s = 0.0025;  // 2.5 ticks at 1 kHz: a fractional ramp
  ForceRamp ramp(limits, 1000.0);
  EXPECT_EQ(ramp.factor(), 0.0);
  std::vector<double> f;
  for (int i = 0; i < 5; ++i) f.push_back(ramp.next());
  EXPECT_EQ(f, (std::vector<double>{0.0, 0.4, 0.8, 1.0, 1.0}));
  ramp.trip();
  EXPECT_NEAR(ramp.next(), 0.8, 1e-12);  // from the top, one step of at most 0.4
  EXPECT_NEAR(ramp.next(), 0.4, 1e-12);
  EXPECT_EQ(ramp.next(), 0.0);
  EXPECT_NEAR(ramp.next(), 0.4, 1e-12);
  ramp.trip();  // while rising: falls again from where it is
  EXPECT_EQ(ramp.next(), 0.0);
  EXPECT_NEAR(ramp.next(), 0.4, 1e-12);
  EXPECT_NEAR(ramp.next(), 0.8, 1e-12);
  EXPECT_EQ(ramp.next(), 1.0);
  EXPECT_EQ(ramp.trips(), 2u);
  EXPECT_EQ(ramp.reduced_ticks(), 7u);
  // No ramp (--ramp-in-s 0): always 1, trips only counted.
  ForceRamp none(DeviceLimits{10.0, 0.0}, 1000.0);
  EXPECT_EQ(none.next(), 1.0);
  none.trip();
  EXPECT_EQ(none.next(), 1.0);
  EXPECT_EQ(none.trips(), 1u);
}

// A silent device or a released dead-man: the factor falls at the ramp's slope, stays at 0
// while it lasts, and rises again after, never stepping.
TEST(Replay, ForceRampHeldDownFallsToZeroStaysThereAndRisesAfter) {
  DeviceLimits limits;
  limits.ramp_in_s = 0.0025;  // 2.5 ticks at 1 kHz
  ForceRamp ramp(limits, 1000.0);
  std::vector<double> f;
  for (int i = 0; i < 4; ++i) f.push_back(ramp.next());
  for (int i = 0; i < 5; ++i) f.push_back(ramp.next(true));
  for (int i = 0; i < 4; ++i) f.push_back(ramp.next());
  const std::vector<double> expected = {0.0, 0.4, 0.8, 1.0,       // ramp-in
                                        0.8, 0.4, 0.0, 0.0, 0.0,  // held down: out, stays
                                        0.4, 0.8, 1.0, 1.0};      // back in
  ASSERT_EQ(f.size(), expected.size());
  for (std::size_t i = 0; i < f.size(); ++i) EXPECT_NEAR(f[i], expected[i], 1e-12) << i;
  EXPECT_EQ(ramp.trips(), 0u);  // not a watchdog trip
  // Held down from the first tick: never rises.
  ForceRamp at_start(limits, 1000.0);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(at_start.next(true), 0.0);
  // No ramp (--ramp-in-s 0): zero at once while held down, 1 after.
  ForceRamp none(DeviceLimits{10.0, 0.0}, 1000.0);
  EXPECT_EQ(none.next(true), 0.0);
  EXPECT_EQ(none.next(), 1.0);
}

TEST(Replay, RepeatedReplaysAreBitIdentical) {
  const engine::DensityField field = engine::generate_volume("block:dims=64");
  const engine::ToolForceModel model(field, small_tool());
  TraceDevice device = press_device();
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
  TraceDevice device = press_device();
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
  TraceDevice device(resample(make_trace(make)), DeviceTransform{});
  const ReplaySummary summary = replay_lockstep(model, device, DeviceLimits{}, nullptr);
  EXPECT_EQ(summary.contact_ticks, 0u);
  EXPECT_EQ(summary.peak_force_n, 0.0);
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
  TraceDevice device(resample(make_trace(make)), DeviceTransform{});
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

TEST(SurfaceChannel, OverflowCoalescesIntoOneSweepAndLosesNothing) {
  SurfaceChangeChannel channel;
  engine::SurfaceChange change;
  change.direction = Vec3d(0, 0, -1);
  change.radius_mm = 2.0;
  const unsigned extra = 10;
  for (unsigned i = 0; i < SurfaceChangeChannel::kCapacity + extra; ++i) {
    change.from_mm = change.position_mm = Vec3d(0, 0, -0.01 * i);
    change.event = i;
    channel.push(change);
  }
  EXPECT_EQ(channel.overflows(), extra);
  EXPECT_TRUE(channel.has_pending());
  engine::SurfaceChange got;
  unsigned popped = 0;
  while (channel.pop(got)) EXPECT_EQ(got.event, static_cast<std::int64_t>(popped++));
  EXPECT_EQ(popped, SurfaceChangeChannel::kCapacity);
  ASSERT_TRUE(channel.flush());
  ASSERT_TRUE(channel.pop(got));
  // The coalesced change sweeps from the first overflowed position to the last one.
  EXPECT_EQ(got.from_mm.z(), -0.01 * SurfaceChangeChannel::kCapacity);
  EXPECT_EQ(got.position_mm.z(), -0.01 * (SurfaceChangeChannel::kCapacity + extra - 1));
  // ... and carries the newest event's number: its deletion covers all of them.
  EXPECT_EQ(got.event, std::int64_t{SurfaceChangeChannel::kCapacity + extra - 1});
  EXPECT_FALSE(channel.pop(got));
}

}  // namespace
}  // namespace hapvox::haptics
