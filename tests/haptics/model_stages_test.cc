// The seams of haptics/model_stages.h hold for a model that is not the voxel model: a
// plane spring (F = k d along +z for a tool centre d below z = 0) and a background stage
// that records what the loops ask of it. Both loops must run it tick by tick, in the
// documented order, and build their summaries from its rows and counters alone.

#include "haptics/model_stages.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <string>
#include <thread>
#include <vector>

#include "haptics/realtime.h"
#include "haptics/replay.h"
#include "haptics/session.h"
#include "test_data.h"

namespace hapvox::haptics {
namespace {

constexpr double kStiffness_n_per_mm = 0.5;

// A press 4 mm below the plane z = 0 and back, 1 kHz.
TraceDevice press_through_plane() {
  TraceMakeOptions make;
  make.shape = TraceShape::kPressRelease;
  make.start_mm = Vec3d(0, 0, 2.0);
  make.travel_mm = 6.0;
  make.speed_mm_s = 20.0;
  make.hold_s = 0.05;
  return TraceDevice(resample(make_trace(make)), DeviceTransform{});
}

class PlaneSpring final : public ForceStage {
 public:
  explicit PlaneSpring(std::size_t nan_at_step) : nan_at_step_(nan_at_step) {}
  Vec3d step(const Vec3d& tool_center_mm, TickRecord& row) noexcept override {
    const double depth_mm = -tool_center_mm.z();
    const bool touching = depth_mm > 0.0;
    if (touching && !was_touching_) ++onsets_;
    was_touching_ = touching;
    row.contact = touching ? 1 : 0;
    row.displacement_mm = Vec3d(0, 0, touching ? -depth_mm : 0.0);
    row.plastic_event = (steps_ % 100 == 0) ? 1 : 0;
    row.queue_depth = static_cast<std::int64_t>(steps_ % 7);
    if (record_calls) calls.push_back("force " + std::to_string(steps_));
    if (steps_++ == nan_at_step_) return Vec3d(NAN, 0, 0);
    return Vec3d(0, 0, touching ? kStiffness_n_per_mm * depth_mm : 0.0);
  }
  ForceStageCounters counters() const noexcept override { return {onsets_, 2}; }
  void write_attributes(SessionWriter& session) const override {
    session.set_attribute("model", std::string("plane-spring"));
  }
  bool record_calls = false;       // lockstep only (it allocates)
  std::vector<std::string> calls;  // the order of the calls

 private:
  std::size_t nan_at_step_;
  std::size_t steps_ = 0;
  bool was_touching_ = false;
  std::uint64_t onsets_ = 0;
};

class RecordingStage final : public BackgroundStage {
 public:
  explicit RecordingStage(std::vector<std::string>* calls) : calls_(calls) {}
  void begin() override {
    if (calls_ != nullptr) calls_->push_back("begin");
  }
  void run_lockstep_tick(std::size_t tick, TickRecord& row, const LockstepRender*) override {
    calls_->push_back("background " + std::to_string(tick));
    row.relaxed_voxels = static_cast<std::int64_t>(tick);
  }
  void run_realtime(const std::atomic<bool>& force_done, std::chrono::steady_clock::time_point,
                    RenderFeed*, BackgroundTiming& timing) override {
    do {  // at least one slice, however late this thread is scheduled
      slices_.fetch_add(1, std::memory_order_relaxed);
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    } while (!force_done.load(std::memory_order_acquire));
    timing.cpu_s = 1.0;
  }
  void fill_realtime_row(TickRecord& row) noexcept override { row.total_mass_units = 42; }
  void wake() noexcept override { woken_.store(true); }
  SculptSummary finish(const LockstepRender*, RenderFeed*, const std::atomic<bool>*) override {
    if (calls_ != nullptr) calls_->push_back("finish");
    SculptSummary s;
    s.deleted_voxels = 7;
    return s;
  }
  std::atomic<int> slices_{0};
  std::atomic<bool> woken_{false};

 private:
  std::vector<std::string>* calls_;
};

void expect_spring_rows(const std::string& path, const TraceDevice& device, std::size_t nan_tick) {
  const std::vector<double> force = read_session_column(path, "/force_n");
  const std::vector<double> scale = read_session_column(path, "/force_scale");
  ASSERT_EQ(force.size(), 3 * device.tick_count());
  const auto spring_n = [&](std::size_t k) {
    const double depth = -device.tool_position_mm(k).z();
    return depth > 0.0 ? kStiffness_n_per_mm * depth : 0.0;
  };
  // From the NaN tick the last safe force falls at the ramp's slope until the ramp is at
  // zero (issue 27: never a step to zero); then the model's force ramps back in.
  bool holding = false;
  for (std::size_t k = 0; k < device.tick_count(); ++k) {
    if (k == nan_tick) holding = true;
    const double expected = scale[k] * (holding ? spring_n(nan_tick - 1) : spring_n(k));
    if (holding && scale[k] == 0.0) holding = false;
    ASSERT_NEAR(force[3 * k + 2], expected, 1e-12) << "tick " << k;
    ASSERT_EQ(force[3 * k], 0.0) << "tick " << k;
  }
}

TEST(ModelStages, LockstepRunsAnyModelInTheDocumentedOrder) {
  TraceDevice device = press_through_plane();
  const std::size_t nan_tick = 150;
  PlaneSpring spring(nan_tick);
  spring.record_calls = true;
  RecordingStage background(&spring.calls);
  const std::string path = testing::scratch_dir() + "/spring.h5";
  SessionWriter session(path);
  SculptSummary sculpted;
  const ReplaySummary summary =
      replay_lockstep(spring, &background, device, DeviceLimits{}, &session, {}, &sculpted);
  session.close();

  // begin; then force k, background k for every tick; then finish.
  ASSERT_EQ(spring.calls.size(), 2 * device.tick_count() + 2);
  EXPECT_EQ(spring.calls.front(), "begin");
  EXPECT_EQ(spring.calls.back(), "finish");
  for (std::size_t k = 0; k < device.tick_count(); ++k) {
    ASSERT_EQ(spring.calls[1 + 2 * k], "force " + std::to_string(k));
    ASSERT_EQ(spring.calls[2 + 2 * k], "background " + std::to_string(k));
  }
  expect_spring_rows(path, device, nan_tick);
  const std::vector<double> relaxed = read_session_column(path, "/relax/relaxed_voxels");
  for (std::size_t k = 0; k < relaxed.size(); ++k) ASSERT_EQ(relaxed[k], double(k));

  // The summary comes from the rows and the stage's counters only.
  std::size_t contact_ticks = 0;
  for (std::size_t k = 0; k < device.tick_count(); ++k) {
    contact_ticks += device.tool_position_mm(k).z() < 0.0 ? 1 : 0;
  }
  EXPECT_EQ(summary.ticks, device.tick_count());
  EXPECT_EQ(summary.contact_ticks, contact_ticks);
  EXPECT_DOUBLE_EQ(summary.contact_time_s, contact_ticks / device.rate_hz());
  EXPECT_EQ(summary.contact_onsets, 1u);
  EXPECT_EQ(summary.nonfinite_forces, 1u + 2u);  // the NaN tick + the stage's own count
  EXPECT_NEAR(summary.peak_force_n, kStiffness_n_per_mm * 4.0, 1e-9);
  EXPECT_EQ(summary.plastic_events, (device.tick_count() + 99) / 100);
  EXPECT_EQ(summary.max_queue_depth, 6u);
  EXPECT_EQ(sculpted.deleted_voxels, 7u);  // from finish()
  EXPECT_EQ(sculpted.plastic_events, summary.plastic_events);
}

TEST(ModelStages, RealtimeRunsAnyModelWithItsBackgroundThread) {
  TraceDevice device = press_through_plane();
  const std::size_t nan_tick = 150;
  PlaneSpring spring(nan_tick);
  RecordingStage background(nullptr);
  const std::string path = testing::scratch_dir() + "/spring_rt.h5";
  SessionWriter session(path);
  SculptSummary sculpted;
  TimingSummary timing;
  RealtimeOptions options;
  options.scheduler.lock_memory = false;
  options.scheduler.realtime_policy = false;
  const ReplaySummary summary = replay_realtime(spring, &background, device, DeviceLimits{},
                                                &session, {}, &sculpted, &timing, options);
  session.close();
  expect_spring_rows(path, device, nan_tick);
  for (double mass : read_session_column(path, "/relax/total_mass_units")) ASSERT_EQ(mass, 42.0);
  EXPECT_GT(background.slices_.load(), 0);
  EXPECT_TRUE(background.woken_.load());
  EXPECT_EQ(timing.relax_cpu_s, 1.0);
  EXPECT_EQ(summary.nonfinite_forces, 1u + 2u);
  EXPECT_EQ(summary.contact_onsets, 1u);
  EXPECT_EQ(sculpted.deleted_voxels, 7u);
  EXPECT_EQ(sculpted.plastic_events, (device.tick_count() + 99) / 100);
}

}  // namespace
}  // namespace hapvox::haptics
