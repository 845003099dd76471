#include "haptics/latency_histogram.h"

#include <algorithm>
#include <cmath>

namespace hapvox::haptics {

std::uint64_t LatencyHistogram::upper_edge(int bucket) {
  if (bucket < kSub) return static_cast<std::uint64_t>(bucket);
  const int shift = (bucket - kSub) / kSub;
  const std::uint64_t sub = static_cast<std::uint64_t>(kSub + (bucket - kSub) % kSub);
  return ((sub + 1) << shift) - 1;
}

std::uint64_t LatencyHistogram::percentile_ns(double pct) const {
  if (count_ == 0) return 0;
  const auto rank = static_cast<std::uint64_t>(
      std::ceil(std::clamp(pct, 0.0, 100.0) / 100.0 * static_cast<double>(count_)));
  const std::uint64_t wanted = std::max<std::uint64_t>(rank, 1);
  std::uint64_t seen = 0;
  for (int b = 0; b < kBuckets; ++b) {
    seen += counts_[b];
    if (seen >= wanted) return std::min(upper_edge(b), max_);
  }
  return max_;
}

}  // namespace hapvox::haptics
