#include "haptics/latency_histogram.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace hapvox::haptics {
namespace {

TEST(LatencyHistogram, BucketsAreExactBelow64AndOneSixtyFourthWideAbove) {
  for (std::uint64_t v = 0; v < 64; ++v) {
    EXPECT_EQ(LatencyHistogram::upper_edge(LatencyHistogram::index(v)), v);
  }
  for (std::uint64_t v : {64ull, 65ull, 127ull, 128ull, 1000ull, 123456ull, 1ull << 40, ~0ull}) {
    const int b = LatencyHistogram::index(v);
    const std::uint64_t upper = LatencyHistogram::upper_edge(b);
    EXPECT_GE(upper, v);
    EXPECT_LE(static_cast<double>(upper - v), static_cast<double>(v) / 64.0) << v;
    EXPECT_LT(b, LatencyHistogram::kBuckets);
  }
  // Buckets tile the line: the next value after a bucket's upper edge is the next bucket.
  for (int b = 0; b + 1 < 2000; ++b) {
    EXPECT_EQ(LatencyHistogram::index(LatencyHistogram::upper_edge(b) + 1), b + 1);
  }
}

TEST(LatencyHistogram, PercentilesNeverReadLowAndAtMostABucketHigh) {
  std::mt19937_64 random(3);
  std::lognormal_distribution<double> latency(std::log(20e3), 0.8);  // ~20 us, long tail
  LatencyHistogram histogram;
  std::vector<std::uint64_t> values;
  for (int i = 0; i < 100000; ++i) {
    const auto v = static_cast<std::uint64_t>(latency(random));
    values.push_back(v);
    histogram.add(static_cast<std::int64_t>(v));
  }
  std::sort(values.begin(), values.end());
  for (double pct : {1.0, 50.0, 99.0, 99.9, 100.0}) {
    const auto rank = static_cast<std::size_t>(std::ceil(pct / 100.0 * values.size()));
    const std::uint64_t exact = values[rank - 1];
    const std::uint64_t read = histogram.percentile_ns(pct);
    EXPECT_GE(read, exact) << pct;
    EXPECT_LE(static_cast<double>(read), static_cast<double>(exact) * (1.0 + 1.0 / 64)) << pct;
  }
  EXPECT_EQ(histogram.max_ns(), values.back());
  EXPECT_EQ(histogram.count(), values.size());
  EXPECT_EQ(LatencyHistogram().percentile_ns(50.0), 0u);
  LatencyHistogram negative;
  negative.add(-5);  // a clock that went backwards counts as zero
  EXPECT_EQ(negative.percentile_ns(50.0), 0u);
}

}  // namespace
}  // namespace hapvox::haptics
