#pragma once
// The lag from a plastic event to the force thread reading a field that has its deletion,
// from what a recording device keeps of each tick (`hapvox bench sculpt`,
// tools/cmd_bench_sculpt.cc). Events are numbered by the force stage
// (engine::SurfaceChange::event) and a publication carries the newest it has taken in
// (DoubleBufferedField::published_event), which each row reports (TickRecord::published_event).

#include <cstddef>
#include <cstdint>
#include <vector>

namespace hapvox::haptics {

/// One tick as the bench's device saw it (times from the device's creation).
struct TickTimes {
  std::int64_t read_ns = 0;           // the tick read its position: its field was taken up
  std::int64_t sent_ns = 0;           // its force was sent: any hand-off was made before
  bool plastic_event = false;         // it emitted a surface change (event numbers count these)
  std::int64_t published_event = -1;  // TickRecord::published_event
  std::int64_t queue_depth = 0;
  double force_n = 0.0;
};

/// The lag from each plastic event (the force of its tick sent) to the first later tick
/// whose field has taken in its deletion (read at that tick's start), over a run's ticks
/// in order. Event e is the e-th tick with plastic_event set (from 0), as the force stage
/// numbers them.
struct DeletionLags {
  std::size_t events = 0;
  std::size_t unseen = 0;  // events no tick of the run read: still queued at its end
  double p50_ms = 0.0, p99_ms = 0.0, max_ms = 0.0;
  double p99_ticks = 0.0;  // the same in ticks (1: the next tick had it)
};
DeletionLags deletion_lags(const std::vector<TickTimes>& ticks);

}  // namespace hapvox::haptics
