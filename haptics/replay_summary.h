#pragma once
// What a replay did, built by one piece of code for both clocks: the lockstep loop adds
// each row as it goes, the realtime loop adds its preallocated rows once the threads are
// joined. Either way the same rows give the same summary.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "haptics/latency_histogram.h"
#include "haptics/session.h"

namespace hapvox::haptics {

class Device;

struct ReplaySummary {
  std::size_t ticks = 0;
  std::size_t contact_ticks = 0;
  double contact_time_s = 0.0;
  double duration_s = 0.0;
  Vec3d first_tool_position_mm = Vec3d::Zero();  // volume space
  Vec3d last_tool_position_mm = Vec3d::Zero();
  double peak_force_n = 0.0;
  std::size_t clamped_ticks = 0;
  std::size_t nonfinite_forces = 0;
  std::size_t motion_faults = 0;  // device samples no hand could have reached (MotionGuard)
  std::uint64_t contact_onsets = 0;
  int trace_gaps = 0;
  double trace_held_s = 0.0;
  // Per-tick compute time (wall clock), microseconds (percentiles to 1.6 %: the upper edge
  // of a LatencyHistogram's bucket).
  double compute_p50_us = 0.0;
  double compute_p99_us = 0.0;
  double compute_max_us = 0.0;
  // Hand-offs to the background stage, from the rows.
  std::uint64_t plastic_events = 0;  // ticks that emitted a surface change
  std::size_t max_queue_depth = 0;   // deepest queue a tick saw
};

/// Median, tail and maximum of a set of durations, in microseconds.
struct DurationStats {
  std::size_t count = 0;
  double p50_us = 0, p99_us = 0, p999_us = 0, max_us = 0;
};

/// Percentile (0..100) of a sample by nearest rank; 0 for an empty sample.
double percentile(std::vector<double> values, double pct);

/// Median, p99, p99.9 and maximum of `values_us` (reorders nothing; copies).
DurationStats duration_stats(const std::vector<double>& values_us);
/// The same of a histogram's durations (each percentile the upper edge of its bucket: at
/// most 1.6 % above the exact one; the maximum exact).
DurationStats duration_stats(const LatencyHistogram& histogram);

/// Accumulates a replay's rows, in tick order, into its summary.
class SummaryBuilder {
 public:
  /// Takes the rate and the trace's gaps from `device`; counts the ticks it is given (a
  /// loop may stop early: a stop request, a live device's end). Its memory is fixed: a run
  /// of any length can be summarised.
  explicit SummaryBuilder(const Device& device);

  /// One tick's row, as sent. `nonfinite`: the model's force was not finite (sent as 0).
  void add(const TickRecord& row, bool nonfinite);
  /// Forces the force stage itself found non-finite and zeroed (its own counter), and the
  /// contacts it began; added once, after the last row.
  ReplaySummary finish(std::uint64_t stage_nonfinite_forces, std::uint64_t contact_onsets);

 private:
  ReplaySummary summary_;
  double rate_hz_;
  double first_time_s_ = 0.0;
  LatencyHistogram compute_;
};

}  // namespace hapvox::haptics
