#include "haptics/replay_summary.h"

#include <algorithm>
#include <cmath>

#include "engine/check.h"
#include "haptics/device.h"

namespace hapvox::haptics {

double percentile(std::vector<double> values, double pct) {
  if (values.empty()) return 0.0;
  const std::size_t rank = static_cast<std::size_t>(
      std::ceil(std::clamp(pct, 0.0, 100.0) / 100.0 * static_cast<double>(values.size())));
  const std::size_t index = rank == 0 ? 0 : rank - 1;
  std::nth_element(values.begin(), values.begin() + index, values.end());
  return values[index];
}

DurationStats duration_stats(const std::vector<double>& values_us) {
  DurationStats stats;
  stats.count = values_us.size();
  if (values_us.empty()) return stats;
  stats.p50_us = percentile(values_us, 50.0);
  stats.p99_us = percentile(values_us, 99.0);
  stats.p999_us = percentile(values_us, 99.9);
  stats.max_us = *std::max_element(values_us.begin(), values_us.end());
  return stats;
}

DurationStats duration_stats(const LatencyHistogram& histogram) {
  DurationStats stats;
  stats.count = histogram.count();
  if (stats.count == 0) return stats;
  stats.p50_us = 1e-3 * static_cast<double>(histogram.percentile_ns(50.0));
  stats.p99_us = 1e-3 * static_cast<double>(histogram.percentile_ns(99.0));
  stats.p999_us = 1e-3 * static_cast<double>(histogram.percentile_ns(99.9));
  stats.max_us = 1e-3 * static_cast<double>(histogram.max_ns());
  return stats;
}

SummaryBuilder::SummaryBuilder(const Device& device) : rate_hz_(device.rate_hz()) {
  summary_.trace_gaps = device.gap_count();
  summary_.trace_held_s = device.held_time_s();
}

void SummaryBuilder::add(const TickRecord& row, bool nonfinite) {
  if (summary_.ticks == 0) {
    first_time_s_ = row.time_s;
    summary_.first_tool_position_mm = row.tool_position_mm;
  }
  summary_.last_tool_position_mm = row.tool_position_mm;
  ++summary_.ticks;
  summary_.duration_s = row.time_s - first_time_s_;
  compute_.add(row.compute_ns);
  summary_.contact_ticks += row.contact;
  summary_.clamped_ticks += row.clamped;
  summary_.nonfinite_forces += nonfinite ? 1 : 0;
  summary_.motion_faults += row.motion_fault;
  summary_.peak_force_n = std::max(summary_.peak_force_n, row.force_n.norm());
  summary_.plastic_events += row.plastic_event;
  summary_.max_queue_depth =
      std::max(summary_.max_queue_depth, static_cast<std::size_t>(row.queue_depth));
}

ReplaySummary SummaryBuilder::finish(std::uint64_t stage_nonfinite_forces,
                                     std::uint64_t contact_onsets) {
  ReplaySummary summary = summary_;
  // Ticks times the period, as the lockstep loop always computed it (bit for bit).
  summary.contact_time_s = static_cast<double>(summary.contact_ticks) * (1.0 / rate_hz_);
  summary.contact_onsets = contact_onsets;
  summary.nonfinite_forces += stage_nonfinite_forces;
  const DurationStats compute = duration_stats(compute_);
  summary.compute_p50_us = compute.p50_us;
  summary.compute_p99_us = compute.p99_us;
  summary.compute_max_us = compute.max_us;
  return summary;
}

}  // namespace hapvox::haptics
