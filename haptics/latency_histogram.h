#pragma once
// A fixed-size histogram of durations for loops that run for as long as a user likes: adding
// a value is a few instructions, with no allocation, so a session of any length keeps the
// same 30 KB. Buckets are exact below 64 ns and 1/64 wide (1.6 %) of their value above, as
// in HdrHistogram; a percentile is the upper edge of the bucket that holds it, so it never
// reads low by more than a bucket, and never high.

#include <array>
#include <bit>
#include <cstdint>

namespace hapvox::haptics {

class LatencyHistogram {
 public:
  static constexpr int kSubBits = 6;  // 64 sub-buckets per power of two
  static constexpr int kSub = 1 << kSubBits;
  static constexpr int kBuckets = kSub + (64 - kSubBits) * kSub;

  void add(std::int64_t ns) {
    const std::uint64_t v = ns > 0 ? static_cast<std::uint64_t>(ns) : 0;
    ++counts_[index(v)];
    ++count_;
    if (v > max_) max_ = v;
  }
  std::uint64_t count() const { return count_; }
  std::uint64_t max_ns() const { return max_; }
  /// The nearest-rank percentile (0..100), as the upper edge of its bucket; 0 when empty.
  std::uint64_t percentile_ns(double pct) const;

  /// The bucket of a value, and the largest value it holds (exposed for the tests).
  static int index(std::uint64_t v) {
    if (v < kSub) return static_cast<int>(v);
    const int shift = (63 - std::countl_zero(v)) - kSubBits;  // >= 0
    return kSub + shift * kSub + static_cast<int>((v >> shift) - kSub);
  }
  static std::uint64_t upper_edge(int bucket);

 private:
  std::array<std::uint64_t, kBuckets> counts_{};
  std::uint64_t count_ = 0;
  std::uint64_t max_ = 0;
};

}  // namespace hapvox::haptics
