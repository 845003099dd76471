#include "haptics/trace_resample.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/input_limits.h"
#include "test_data.h"

namespace hapvox::haptics {
namespace {

using ::hapvox::testing::input_error_of;
using ::testing::HasSubstr;

// Linear motion p(t) = a + b t, so interpolation on it must be exact.
Vec3d linear_motion(double t) { return Vec3d(1.0, -2.0, 0.5) + t * Vec3d(3.0, 0.25, -7.0); }

Trace sample_linear(const std::vector<double>& times) {
  Trace trace;
  for (double t : times) {
    trace.time_s.push_back(t);
    trace.position_mm.push_back(linear_motion(t));
  }
  return trace;
}

void expect_resampled_linear(const Trace& trace) {
  const ResampledTrace out = resample(trace);
  const double t0 = trace.time_s.front();
  const std::size_t expected =
      static_cast<std::size_t>(std::floor((trace.time_s.back() - t0) * 1000.0 + 1e-9)) + 1;
  ASSERT_EQ(out.time_s.size(), expected);
  ASSERT_EQ(out.position_mm.size(), expected);
  ASSERT_EQ(out.holding.size(), expected);
  EXPECT_EQ(out.gap_count, 0);
  EXPECT_EQ(out.held_time_s, 0.0);
  for (std::size_t k = 0; k < expected; ++k) {
    EXPECT_EQ(out.time_s[k], t0 + static_cast<double>(k) / 1000.0);
    EXPECT_LT((out.position_mm[k] - linear_motion(out.time_s[k])).norm(), 1e-9) << k;
    EXPECT_EQ(out.holding[k], 0);
  }
  EXPECT_LE(out.time_s.back(), trace.time_s.back() + 1e-12);
}

TEST(TraceResampleTest, From100Hz) {
  std::vector<double> times;
  for (int i = 0; i <= 200; ++i) times.push_back(0.25 + i / 100.0);
  expect_resampled_linear(sample_linear(times));
  EXPECT_EQ(resample(sample_linear(times)).time_s.size(), 2001u);
}

TEST(TraceResampleTest, FromJitteredTimes) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> step(0.0005, 0.02);
  std::vector<double> times = {-0.3};
  while (times.back() < 1.7) times.push_back(times.back() + step(rng));
  expect_resampled_linear(sample_linear(times));
}

TEST(TraceResampleTest, From7kHz) {
  std::vector<double> times;
  for (int i = 0; i <= 7000; ++i) times.push_back(i / 7000.0);
  expect_resampled_linear(sample_linear(times));
  EXPECT_EQ(resample(sample_linear(times)).time_s.size(), 1001u);
}

TEST(TraceResampleTest, GapHoldsTheTool) {
  // 100 Hz samples, then nothing between 0.5 s and 0.8 s.
  std::vector<double> times;
  for (int i = 0; i <= 50; ++i) times.push_back(i / 100.0);
  for (int i = 80; i <= 100; ++i) times.push_back(i / 100.0);
  const Trace trace = sample_linear(times);
  const ResampledTrace out = resample(trace, {.rate_hz = 1000.0, .max_gap_s = 0.05});
  ASSERT_EQ(out.time_s.size(), 1001u);
  EXPECT_EQ(out.gap_count, 1);
  EXPECT_NEAR(out.held_time_s, 0.3, 1e-12);
  const Vec3d held = linear_motion(0.5);
  for (std::size_t k = 0; k < out.time_s.size(); ++k) {
    const double t = out.time_s[k];
    if (t > 0.5 + 1e-9 && t < 0.8 - 1e-9) {
      EXPECT_EQ(out.holding[k], 1) << k;
      EXPECT_LT((out.position_mm[k] - held).norm(), 1e-12) << k;
    } else if (t < 0.5 - 1e-9 || t > 0.8 + 1e-9) {
      EXPECT_EQ(out.holding[k], 0) << k;
      EXPECT_LT((out.position_mm[k] - linear_motion(t)).norm(), 1e-9) << k;
    }
  }
  // With a larger allowance the same step is interpolated.
  const ResampledTrace loose = resample(trace, {.rate_hz = 1000.0, .max_gap_s = 0.5});
  EXPECT_EQ(loose.gap_count, 0);
  EXPECT_EQ(loose.held_time_s, 0.0);
}

TEST(TraceResampleTest, BadOptions) {
  const Trace trace = sample_linear({0, 1});
  EXPECT_THAT(input_error_of([&] { resample(trace, {.rate_hz = 0.0}); }),
              HasSubstr("resample: rate"));
  EXPECT_THAT(input_error_of([&] { resample(trace, {.rate_hz = 1000.0, .max_gap_s = -1.0}); }),
              HasSubstr("resample: max gap"));
  EXPECT_THAT(input_error_of([&] { resample(sample_linear({0})); }),
              HasSubstr("resample: need at least 2 samples"));
}

TEST(TraceResampleTest, TheTracesProblemsNameItsFile) {
  // The time span's error named "resample:", which no user gave.
  EXPECT_EQ(input_error_of([&] { resample(sample_linear({0}), {}, "probe.csv"); }),
            "probe.csv: need at least 2 samples, found 1");
  EXPECT_EQ(input_error_of([&] {
              resample(sample_linear({0, 9e5}), {}, "probe.csv");
            }),
            "probe.csv: its time span of 9e+05 s at 1000 Hz makes 900000001 rows, over the "
            "limit of 50000000 rows (raise it with --max-trace-rows)");
}

TEST(TraceResampleTest, TicksPastTheRowLimitAreRefusedBeforeAllocating) {
  engine::InputLimits& limits = engine::input_limits();
  const engine::InputLimits saved = limits;
  limits.max_trace_rows = 1001;
  const Trace trace = sample_linear({0, 1});  // 1001 ticks at 1 kHz: at the limit
  EXPECT_EQ(resample(trace, {}, "probe.csv").time_s.size(), 1001u);
  EXPECT_EQ(input_error_of([&] { resample(trace, {.rate_hz = 2000.0}, "probe.csv"); }),
            "probe.csv: its time span of 1 s at 2000 Hz makes 2001 rows, over the limit of 1001 "
            "rows (raise it with --max-trace-rows)");
  limits = saved;
}

}  // namespace
}  // namespace hapvox::haptics
