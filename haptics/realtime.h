#pragma once
// Realtime replay: the same force stage as the lockstep replay, paced by the wall clock on
// its own thread, with the relaxation on a second thread and the session written from the
// calling thread.
//
//   force thread     absolute 1 kHz deadlines (sleep, then spin the last stretch); each
//                    tick: pick the field buffer to read, step the model, make the force
//                    safe, push any surface change, fill the preallocated row. No locks,
//                    no allocation, no I/O, no exceptions after start.
//   relax thread     slices of bounded work (run_relax_stage: at most
//                    max_deletions_per_slice deletions, then at most relax_voxels_per_slice
//                    relaxation steps), each followed by the publication of changed voxels
//                    into the back buffer of a DoubleBufferedField; exact mass measured
//                    every ~50 ms while the grid changes. With no work it sleeps until the
//                    force thread pushes a change (SurfaceChangeChannel::wait_for_arrival).
//   calling thread   appends finished rows to the session (~10 times a second) and
//                    reports progress.

#include <atomic>
#include <cstdint>
#include <functional>

#include <string>
#include <vector>

#include "haptics/double_buffered_field.h"
#include "haptics/render_feed.h"
#include "haptics/replay.h"
#include "haptics/scheduler.h"

namespace hapvox::haptics {

struct RealtimeSculpt {
  engine::MassGrid* mass = nullptr;
  DoubleBufferedField* field = nullptr;  // the model must read field->buffer(0)
  SurfaceChangeChannel* channel = nullptr;
  std::size_t relax_voxels_per_slice = 2000;  // relaxation steps per slice (MassGrid::relax)
  std::size_t max_deletions_per_slice = 8;    // queued surface changes applied per slice
};

/// Median, tail and maximum of a set of durations, in microseconds.
struct DurationStats {
  std::size_t count = 0;
  double p50_us = 0, p99_us = 0, p999_us = 0, max_us = 0;
};

struct TimingSummary {
  double rate_hz = 0;  // target
  // Force thread. Lateness = actual start - scheduled start of a tick.
  DurationStats lateness;
  std::size_t missed_deadlines = 0;         // ticks that ended after the next tick's deadline
  std::size_t watchdog_trips = 0;           // ticks that overran the watchdog (each starts a ramp)
  std::uint64_t watchdog_ramped_ticks = 0;  // ticks sent ramped down (factor < 1) by trips
  double achieved_rate_hz = 0;
  double wall_time_s = 0;
  double force_cpu_s = 0;               // force thread CPU time over the loop
  long force_involuntary_switches = 0;  // times the kernel preempted the force thread
  std::size_t stalled_ticks = 0;        // started more than a full period late
  double machine_steal_s = 0;           // hypervisor steal time, all CPUs, over the run
  SchedulerReport scheduler;
  // Relaxation thread: one slice = apply queued deletions, relax a budget, publish.
  DurationStats relax_slice;
  double relax_busy_fraction = 0;  // time in slices / wall time
  double relax_cpu_s = 0;
  std::size_t relax_slice_max_deletions = 0;  // most deletions one slice applied
  std::size_t relax_slice_max_steps = 0;      // most relaxation steps one slice took
  std::vector<std::int64_t> relax_slice_ns;   // every slice that did work, in order
  std::vector<std::int64_t> relax_slice_start_ns;
  // Render thread (empty without a render loop).
  DurationStats render_frame;           // frame times
  double render_fps = 0;                // frames / the render thread's span
  std::uint64_t render_queue_full = 0;  // times the voxel queue was full (nothing lost)
  RenderTiming render;
};

/// Median, p99, p99.9 and maximum of `values_us` (reorders nothing; copies).
DurationStats duration_stats(const std::vector<double>& values_us);

/// Called on the force thread right before its first tick and right after its last one
/// (tests use them to prove the loop does not allocate; profilers to tag the thread).
struct ForceThreadHooks {
  std::function<void()> loop_started;
  std::function<void()> loop_finished;
  /// Called at the start of every tick, before the force is computed (tests use it to
  /// inject a stall). Empty in production.
  std::function<void(std::size_t tick)> before_tick;
};

struct RealtimeOptions {
  SchedulerOptions scheduler;
  /// A tick that ends more than this many periods after its deadline counts a watchdog
  /// trip: its own (late but fresh) force is sent, and from the next tick on the force is
  /// ramped down to zero and back in at the ramp-in's slope (ForceRamp), never stepped.
  double watchdog_periods = 1.0;
  ForceThreadHooks hooks;
  /// With a loop, a third thread renders: it is fed the force thread's tool pose and the
  /// relaxation thread's changed voxels (haptics/render_feed.h), never blocking either.
  RenderLoop render_loop;
};

/// Replays `device` in realtime. With `sculpt`, plastic changes flow to the relaxation
/// thread and back into the field the force thread reads.
ReplaySummary replay_realtime(const engine::ToolForceModel& model, const TraceDevice& device,
                              const DeviceLimits& limits, SessionWriter* session,
                              const ProgressFn& progress, RealtimeSculpt* sculpt,
                              SculptSummary* sculpt_summary, TimingSummary* timing,
                              const RealtimeOptions& options = {});

}  // namespace hapvox::haptics
