#include "haptics/force_safety.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "engine/volume_io.h"
#include "haptics/replay.h"
#include "haptics/voxel_model.h"

namespace hapvox::haptics {
namespace {

// Issue 27: `-E 1e170` sent 0 N while the report said "clamped at 10 N": |F|^2 overflowed,
// and the clamp scaled the force by 10 / inf.
TEST(ForceSafety, AForceWhoseSquareOverflowsIsClampedNotZeroed) {
  const DeviceLimits limits;  // 10 N
  bool clamped = false, nonfinite = false;
  const Vec3d huge(1e170, -1e170, 0.0);
  ASSERT_FALSE(std::isfinite(huge.squaredNorm()));
  const Vec3d f = safe_force(huge, 1.0, limits, &clamped, &nonfinite);
  EXPECT_TRUE(clamped);
  EXPECT_FALSE(nonfinite);
  EXPECT_NEAR(f.norm(), 10.0, 1e-12);
  EXPECT_NEAR(f.x(), 10.0 / std::sqrt(2.0), 1e-12);  // direction kept
  EXPECT_NEAR(f.y(), -10.0 / std::sqrt(2.0), 1e-12);
  const double biggest = std::numeric_limits<double>::max();  // |F| itself overflows
  EXPECT_NEAR(
      safe_force(Vec3d(biggest, biggest, biggest), 0.5, limits, &clamped, &nonfinite).norm(), 5.0,
      1e-12);
}

TEST(MotionGuard, ASpikeIsHeldAndTheNextSampleIsUsedAgain) {
  const DeviceLimits limits;  // 10 m/s: 10 mm a tick at 1 kHz
  MotionGuard guard(limits, 1000.0);
  EXPECT_DOUBLE_EQ(guard.max_step_mm(), 10.0);
  Vec3d used;
  EXPECT_FALSE(guard.judge(Vec3d(1, 2, 3), used));
  EXPECT_EQ(used, Vec3d(1, 2, 3));
  EXPECT_FALSE(guard.judge(Vec3d(10, 2, 3), used));  // 9 mm in a tick: a fast hand
  for (double spike : {1e9, 1e300, std::numeric_limits<double>::infinity(),
                       std::numeric_limits<double>::quiet_NaN()}) {
    EXPECT_TRUE(guard.judge(Vec3d(spike, 2, 3), used)) << spike;
    EXPECT_EQ(used, Vec3d(10, 2, 3)) << spike;  // held where it was
    EXPECT_FALSE(guard.judge(Vec3d(11, 2, 3), used)) << spike;
    EXPECT_EQ(used, Vec3d(11, 2, 3));
    EXPECT_FALSE(guard.judge(Vec3d(10, 2, 3), used)) << spike;
  }
  // 30 mm in a tick, within reach: a jump.
  EXPECT_TRUE(guard.judge(Vec3d(40, 2, 3), used));
  EXPECT_EQ(used, Vec3d(10, 2, 3));
  EXPECT_EQ(guard.faults(), 5u);
}

TEST(MotionGuard, ADeviceThatRelocatesIsFollowedAfterOneFault) {
  MotionGuard guard(DeviceLimits{}, 1000.0);
  Vec3d used;
  EXPECT_FALSE(guard.judge(Vec3d(0, 0, 0), used));
  EXPECT_TRUE(guard.judge(Vec3d(500, 0, 0), used));  // re-homed, or a trace's gap
  EXPECT_EQ(used, Vec3d::Zero());
  EXPECT_FALSE(guard.judge(Vec3d(501, 0, 0), used));  // it follows on from the jump
  EXPECT_EQ(used, Vec3d(501, 0, 0));
  // Beyond reach (10 m) it is never followed, however steady.
  EXPECT_TRUE(guard.judge(Vec3d(2e4, 0, 0), used));
  EXPECT_TRUE(guard.judge(Vec3d(2e4, 0, 0), used));
  EXPECT_EQ(used, Vec3d(501, 0, 0));
  // After k faulted ticks a hand could have gone k + 1 steps.
  EXPECT_FALSE(guard.judge(Vec3d(525, 0, 0), used));
}

// A tool pressed 1 mm into the block over 0.15 s and held; tick `spike` (if any) reads
// `spike_mm` for x.
TraceDevice held_press(std::size_t ticks, std::size_t spike, double spike_mm) {
  ResampledTrace trace;
  for (std::size_t k = 0; k < ticks; ++k) {
    trace.time_s.push_back(static_cast<double>(k) / 1000.0);
    // Block face at z = 31.5: an 8 mm tool centred at 35.5 touches it, at 34.5 is 1 mm in.
    const double pressed = static_cast<double>(std::min<std::size_t>(k, 150)) / 150.0;
    trace.position_mm.push_back(Vec3d(32.2, 31.7, 36.0 - 1.5 * pressed));
    trace.holding.push_back(0);
  }
  if (spike < ticks) trace.position_mm[spike].x() = spike_mm;
  return TraceDevice(std::move(trace), DeviceTransform{});
}

struct VoxelRun {
  std::vector<Vec3d> sent_n;
  std::vector<Vec3d> displacement_mm;
  std::vector<std::uint8_t> motion_fault;
  std::vector<std::uint8_t> contact;
};

VoxelRun run_voxel(TraceDevice device, const DeviceLimits& limits) {
  const engine::DensityField field = engine::generate_volume("block:dims=64");
  engine::ToolForceOptions o;
  o.tool.diameter_mm = 8.0;
  const engine::ToolForceModel model(field, o);
  VoxelForceStage stage(model);
  ForceSafety safety(limits, device.rate_hz());
  VoxelRun run;
  for (std::size_t tick = 0; tick < device.tick_count(); ++tick) {
    TickRecord row;
    run_force_stage(stage, device, tick, limits, safety, row);
    run.sent_n.push_back(row.force_n);
    run.displacement_mm.push_back(row.displacement_mm);
    run.motion_fault.push_back(row.motion_fault);
    run.contact.push_back(row.contact);
  }
  return run;
}

// Issue 27: one trace row at x = 1e9 (or 1e300) took the force to 0, then to 10 N clamped
// for 99 ticks, and stored a displacement of 2.5e294 mm. Now the sample is a motion fault:
// the model stays where it was, and the force ramps out and back in at the ramp's slope.
TEST(ForceSafety, ASpikeInContactRampsTheForceOutAndInAtTheRampsSlope) {
  const DeviceLimits limits;  // 10 N, 0.1 s ramp: at most 0.1 N a tick
  const std::size_t ticks = 600, spike = 300, ramp_ticks = 100;
  const VoxelRun calm = run_voxel(held_press(ticks, ticks, 0.0), limits);
  const Vec3d held_n = calm.sent_n[spike];
  ASSERT_GT(held_n.z(), 0.1);  // pressed: the force pushes the tool out (+z)
  ASSERT_EQ(calm.sent_n[ticks - 1], held_n);
  for (double spike_mm : {1e9, 1e300}) {
    const VoxelRun run = run_voxel(held_press(ticks, spike, spike_mm), limits);
    double largest_step_n = 0.0;
    for (std::size_t k = 0; k < ticks; ++k) {
      ASSERT_TRUE(run.sent_n[k].allFinite()) << k;
      ASSERT_TRUE(run.displacement_mm[k].allFinite()) << k;
      ASSERT_LT(run.displacement_mm[k].norm(), 5.0) << k;
      ASSERT_EQ(run.contact[k], calm.contact[k]) << k;  // contact never lost to the spike
      ASSERT_EQ(run.motion_fault[k], k == spike ? 1 : 0) << k;
      // Held still from tick 150 on: every step after it is the ramp's.
      if (k > 160) {
        largest_step_n = std::max(largest_step_n, (run.sent_n[k] - run.sent_n[k - 1]).norm());
      }
    }
    // Before the spike as without it; at the spike the held force starts falling; zero
    // one ramp later; back in full one ramp after that.
    EXPECT_EQ(run.sent_n[spike - 1], held_n);
    EXPECT_NEAR(run.sent_n[spike].z(), 0.99 * held_n.z(), 1e-12);
    EXPECT_EQ(run.sent_n[spike + ramp_ticks - 1], Vec3d::Zero());
    EXPECT_EQ(run.sent_n[spike + 2 * ramp_ticks - 1], held_n);
    EXPECT_EQ(run.displacement_mm[ticks - 1], calm.displacement_mm[ticks - 1]);
    EXPECT_LE(largest_step_n, held_n.norm() / ramp_ticks + 1e-12) << spike_mm;
  }
}

// A model force that is not finite for one tick: the last safe force is sent, falling,
// never a step to zero.
class FlakyStage final : public ForceStage {
 public:
  explicit FlakyStage(std::size_t bad_tick) : bad_tick_(bad_tick) {}
  Vec3d step(const Vec3d&, TickRecord&) noexcept override {
    return tick_++ == bad_tick_ ? Vec3d(std::nan(""), 0, 0) : Vec3d(0, 0, 2.0);
  }
  ForceStageCounters counters() const noexcept override { return {}; }
  void write_attributes(SessionWriter&) const override {}

 private:
  std::size_t bad_tick_;
  std::size_t tick_ = 0;
};

TEST(ForceSafety, ANonFiniteForceFallsFromTheLastSafeOneNeverSteps) {
  const DeviceLimits limits;
  const std::size_t ticks = 500, bad = 250;
  FlakyStage stage(bad);
  TraceDevice device = held_press(ticks, ticks, 0.0);
  ForceSafety safety(limits, device.rate_hz());
  std::vector<Vec3d> sent;
  std::size_t faults = 0;
  for (std::size_t tick = 0; tick < ticks; ++tick) {
    TickRecord row;
    faults += run_force_stage(stage, device, tick, limits, safety, row) ? 1 : 0;
    sent.push_back(row.force_n);
  }
  EXPECT_EQ(faults, 1u);
  EXPECT_EQ(sent[bad - 1], Vec3d(0, 0, 2.0));
  EXPECT_NEAR(sent[bad].z(), 0.99 * 2.0, 1e-12);
  for (std::size_t k = 1; k < ticks; ++k) {
    ASSERT_LE((sent[k] - sent[k - 1]).norm(), 2.0 / 100 + 1e-12) << k;
  }
  EXPECT_EQ(sent[ticks - 1], Vec3d(0, 0, 2.0));
}

}  // namespace
}  // namespace hapvox::haptics
