// The mouse device: a window's target becomes the tool's position no faster than the
// device's speed, and, driving the realtime loop from another thread as a window does, the
// force presses, ramps out when the dead-man is released and the session ends on request.

#include "haptics/mouse_device.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <thread>

#include "alloc_count.h"
#include "engine/volume_io.h"
#include "haptics/realtime.h"
#include "haptics/session.h"
#include "haptics/voxel_model.h"

namespace hapvox::haptics {
namespace {

TEST(MouseDevice, TheToolFollowsTheTargetNoFasterThanItsSpeed) {
  MouseDeviceOptions options;
  options.rate_hz = 1000.0;
  options.max_speed_mm_s = 200.0;  // 0.2 mm a tick
  options.start_mm = Vec3d(1.0, 2.0, 3.0);
  MouseDevice device(options);
  DeviceReading reading;
  device.read(0, reading);  // no target yet: the tool stays at the start
  EXPECT_EQ(reading.position_mm, options.start_mm);
  EXPECT_EQ(reading.sequence, 0);
  const Vec3d target(1.0 + 0.6, 2.0 + 0.8, 3.0);  // 1 mm away along (0.6, 0.8, 0)
  device.set_target(target, false);
  Vec3d before = reading.position_mm;
  std::size_t tick = 1;
  for (; tick < 20 && reading.position_mm != target; ++tick) {
    device.read(tick, reading);
    const Vec3d step = reading.position_mm - before;
    EXPECT_LE(step.norm(), 0.2 + 1e-12) << "tick " << tick;
    EXPECT_NEAR(step.normalized().dot(Vec3d(0.6, 0.8, 0.0)), 1.0, 1e-12);  // straight at it
    EXPECT_EQ(reading.time_s, static_cast<double>(tick) / 1000.0);
    EXPECT_EQ(reading.sequence, 1);
    EXPECT_FALSE(reading.holding);
    before = reading.position_mm;
  }
  // Five steps of 0.2 mm (a sixth for rounding at most), then exactly there, and it stays.
  EXPECT_GE(tick, 6u);
  EXPECT_LE(tick, 7u);
  device.read(tick, reading);
  EXPECT_EQ(reading.position_mm, target);
}

TEST(MouseDevice, TheDeadManTheEndAndTheFeedbackReachTheirThreads) {
  MouseDevice device(MouseDeviceOptions{});
  DeviceReading reading;
  device.set_target(Vec3d(0.0, 0.0, 0.1), true);
  device.read(0, reading);
  EXPECT_TRUE(reading.released);
  device.set_target(Vec3d(0.0, 0.0, 0.1), false);
  device.read(1, reading);
  EXPECT_FALSE(reading.released);
  EXPECT_EQ(reading.sequence, 2);
  EXPECT_EQ(device.targets_set(), 2u);
  // A target that is not finite moves nothing.
  device.set_target(Vec3d(NAN, 0.0, 0.0), false);
  device.read(2, reading);
  EXPECT_TRUE(reading.position_mm.allFinite());
  EXPECT_EQ(device.targets_set(), 2u);

  EXPECT_EQ(device.feedback().tick, -1);
  TickRecord row;
  row.tool_position_mm = Vec3d(1.0, 2.0, 3.0);
  row.force_scale = 0.5;
  row.contact = 1;
  row.force_n = Vec3d(0.0, 0.0, 1.25);
  device.send(2, row.force_n, row, false);
  const DeviceFeedback feedback = device.feedback();
  EXPECT_EQ(feedback.tick, 2);
  EXPECT_EQ(feedback.force_n[2], 1.25);
  EXPECT_EQ(feedback.position_mm[1], 2.0);
  EXPECT_EQ(feedback.force_scale, 0.5);
  EXPECT_TRUE(feedback.contact);

  EXPECT_FALSE(device.finished());
  device.request_end();
  EXPECT_TRUE(device.finished());
  EXPECT_EQ(device.tick_count(), Device::kUnbounded);
}

// A "window" thread presses the tool into the block, releases the dead-man, then ends the
// session, while the realtime loop runs the voxel model with the mouse as its device.
TEST(MouseDevice, ARealtimeSessionPressesRampsOutOnTheDeadManAndEndsOnRequest) {
  const engine::DensityField field = engine::generate_volume("block:dims=48");
  engine::ToolForceOptions tool;
  tool.tool.diameter_mm = 8.0;
  const engine::ToolForceModel model(field, tool);
  MouseDeviceOptions options;
  options.start_mm = Vec3d(24.0, 24.0, 29.0);  // above the block
  MouseDevice device(options);
  std::atomic<bool> loop_started{false};
  std::thread window([&] {
    while (!loop_started.load()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    device.set_target(Vec3d(24.0, 24.0, 26.0), false);  // 3 mm down: into the block
    std::this_thread::sleep_for(std::chrono::milliseconds(400));
    device.set_target(Vec3d(24.0, 24.0, 26.0), true);  // the dead-man lets go
    std::this_thread::sleep_for(std::chrono::milliseconds(400));
    device.request_end();
  });
  RealtimeOptions realtime;
  realtime.scheduler.lock_memory = false;
  std::uint64_t at_start = 0, allocations = ~0ull;
  realtime.hooks.loop_started = [&] {
    at_start = testing::allocations_on_this_thread;
    loop_started.store(true);
  };
  realtime.hooks.loop_finished = [&] {
    allocations = testing::allocations_on_this_thread - at_start;
  };
  const std::string path =
      (std::filesystem::path(::testing::TempDir()) / "mouse_session.h5").string();
  SessionWriter session(path);
  TimingSummary timing;
  const ReplaySummary summary = replay_realtime(model, device, DeviceLimits{}, &session, {},
                                                nullptr, nullptr, &timing, realtime);
  session.close();
  window.join();
  EXPECT_EQ(allocations, 0u);
  // It ran until asked to end (~0.9 s), not forever.
  EXPECT_GT(summary.ticks, 700u);
  EXPECT_LT(summary.ticks, 3000u);
  const std::vector<double> force = read_session_column(path, "/force_n");
  const std::vector<double> scale = read_session_column(path, "/force_scale");
  const std::vector<double> position = read_session_column(path, "/device_position_mm");
  const std::size_t n = scale.size();
  ASSERT_EQ(n, summary.ticks);
  // Pressed: the tool reached the target and the block pushed it back up (+z), at full force.
  // Pressed at full force at some tick.
  double pressed_n = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    if (position[3 * k + 2] == 26.0 && scale[k] == 1.0) pressed_n = force[3 * k + 2];
  }
  EXPECT_GT(pressed_n, 0.5);
  // Released: the run ends with the force at zero while the tool is still pressed in (the
  // dead-man held for 0.4 s, the ramp takes 0.1 s = 100 ticks), ...
  std::size_t zero_from = n;
  while (zero_from > 0 && scale[zero_from - 1] == 0.0) --zero_from;
  EXPECT_GE(n - zero_from, 150u);
  for (std::size_t k = zero_from; k < n; ++k) {
    EXPECT_EQ(force[3 * k + 2], 0.0) << "tick " << k;
    EXPECT_EQ(position[3 * k + 2], 26.0) << "tick " << k;
  }
  // ... reached by a ramp of at most 100 ticks, never a step (a loaded machine's watchdog
  // may have started it from below full force).
  ASSERT_GT(zero_from, 0u);
  std::size_t ramp_from = zero_from - 1;
  while (ramp_from > 0 && scale[ramp_from - 1] > scale[ramp_from]) {
    EXPECT_LE(std::abs(force[3 * ramp_from + 2] - force[3 * (ramp_from - 1) + 2]),
              10.0 / 100.0 + 1e-9);
    --ramp_from;
  }
  EXPECT_LE(zero_from - ramp_from, 101u);
}

}  // namespace
}  // namespace hapvox::haptics
