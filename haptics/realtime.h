#pragma once
// Realtime replay: the same force stage as the lockstep replay, paced by the wall clock on
// its own thread, with the relaxation on a second thread and the session written from the
// calling thread.
//
//   force thread     absolute 1 kHz deadlines (sleep, then spin the last stretch); each
//                    tick: pick the field buffer to read, step the model, make the force
//                    safe, push any surface change, fill the preallocated row. No locks,
//                    no allocation, no I/O, no exceptions after start.
//   relax thread     deletions, a slice of relaxation, publication of changed voxels into
//                    the back buffer of a DoubleBufferedField; exact mass measured
//                    every ~50 ms.
//   calling thread   appends finished rows to the session (~10 times a second) and
//                    reports progress.

#include <atomic>
#include <cstdint>
#include <functional>

#include "haptics/double_buffered_field.h"
#include "haptics/replay.h"

namespace hapvox::haptics {

struct RealtimeSculpt {
  engine::MassGrid* mass = nullptr;
  DoubleBufferedField* field = nullptr;  // the model must read field->buffer(0)
  SurfaceChangeChannel* channel = nullptr;
  std::size_t relax_voxels_per_slice = 2000;
};

struct TimingSummary {
  double lateness_p50_us = 0, lateness_p99_us = 0, lateness_p999_us = 0, lateness_max_us = 0;
  std::size_t missed_deadlines = 0;  // ticks that ended after the next tick's deadline
  double achieved_rate_hz = 0;
  double wall_time_s = 0;
};

/// Called on the force thread right before its first tick and right after its last one
/// (tests use them to prove the loop does not allocate; profilers to tag the thread).
struct ForceThreadHooks {
  std::function<void()> loop_started;
  std::function<void()> loop_finished;
};

/// Replays `device` in realtime. With `sculpt`, plastic changes flow to the relaxation
/// thread and back into the field the force thread reads.
ReplaySummary replay_realtime(const engine::ToolForceModel& model, const TraceDevice& device,
                              const DeviceLimits& limits, SessionWriter* session,
                              const ProgressFn& progress, RealtimeSculpt* sculpt,
                              SculptSummary* sculpt_summary, TimingSummary* timing,
                              const ForceThreadHooks* hooks = nullptr);

}  // namespace hapvox::haptics
