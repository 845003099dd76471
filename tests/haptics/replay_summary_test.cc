#include "haptics/replay_summary.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "haptics/replay.h"

namespace hapvox::haptics {
namespace {

TEST(ReplaySummary, PercentileByNearestRank) {
  EXPECT_EQ(percentile({}, 50), 0.0);
  EXPECT_EQ(percentile({5, 1, 3, 2, 4}, 50), 3.0);
  EXPECT_EQ(percentile({5, 1, 3, 2, 4}, 100), 5.0);
  EXPECT_EQ(percentile({5, 1, 3, 2, 4}, 0), 1.0);
}

// 100 ticks at 500 Hz with hand-made rows: every figure of the summary follows from them.
TEST(ReplaySummary, BuiltFromTheRowsAndTheStageCounters) {
  TraceMakeOptions make;
  make.shape = TraceShape::kPress;
  make.travel_mm = 1.0;
  make.speed_mm_s = 10.0;
  make.hold_s = 0.0;
  make.rate_hz = 500.0;
  ResampleOptions resample_options;
  resample_options.rate_hz = 500.0;
  TraceDevice device(resample(make_trace(make), resample_options), DeviceTransform{});
  ASSERT_GE(device.tick_count(), 50u);
  SummaryBuilder builder(device);
  const std::size_t n = device.tick_count();
  for (std::size_t k = 0; k < n; ++k) {
    TickRecord row;
    row.time_s = device.time_s(k);
    row.compute_ns = static_cast<std::int64_t>(1000 * (k + 1));  // 1..n us
    row.contact = k % 4 == 0 ? 1 : 0;
    row.clamped = k == 3 ? 1 : 0;
    row.force_n = Vec3d(0, 3.0 * std::sin(0.1 * static_cast<double>(k)), 0);
    row.plastic_event = k % 10 == 0 ? 1 : 0;
    row.queue_depth = k == 17 ? 9 : 1;
    builder.add(row, k == 5);
  }
  const ReplaySummary s = builder.finish(4, 2);
  std::size_t contact = 0;
  double peak = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    contact += k % 4 == 0 ? 1 : 0;
    peak = std::max(peak, std::abs(3.0 * std::sin(0.1 * static_cast<double>(k))));
  }
  EXPECT_EQ(s.ticks, n);
  EXPECT_EQ(s.contact_ticks, contact);
  EXPECT_DOUBLE_EQ(s.contact_time_s, static_cast<double>(contact) / 500.0);
  EXPECT_DOUBLE_EQ(s.duration_s, device.time_s(n - 1) - device.time_s(0));
  EXPECT_EQ(s.clamped_ticks, 1u);
  EXPECT_EQ(s.nonfinite_forces, 1u + 4u);
  EXPECT_EQ(s.contact_onsets, 2u);
  EXPECT_DOUBLE_EQ(s.peak_force_n, peak);
  EXPECT_EQ(s.plastic_events, (n + 9) / 10);
  EXPECT_EQ(s.max_queue_depth, 9u);
  // Nearest rank of 1..n us, read off a histogram: never low, at most a bucket (1/64) high.
  const double p50 = std::ceil(0.5 * static_cast<double>(n));
  const double p99 = std::ceil(0.99 * static_cast<double>(n));
  EXPECT_GE(s.compute_p50_us, p50);
  EXPECT_LE(s.compute_p50_us, p50 * (1.0 + 1.0 / 64));
  EXPECT_GE(s.compute_p99_us, p99);
  EXPECT_LE(s.compute_p99_us, p99 * (1.0 + 1.0 / 64));
  EXPECT_DOUBLE_EQ(s.compute_max_us, static_cast<double>(n));
}

}  // namespace
}  // namespace hapvox::haptics
