#include "haptics/replay.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>

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
  make.travel_mm = 3.0;
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
