#pragma once
// Realtime replay: the same force stage as the lockstep replay, paced by the wall clock on
// its own thread, with the model's background stage (the relaxation of the voxel model)
// on a second thread and the session written from the calling thread. Nothing here names
// a concrete model (haptics/model_stages.h); the voxel model's stages are described in
// haptics/voxel_model.h.
//
//   force thread     absolute 1 kHz deadlines (sleep, then spin the last stretch); each
//                    tick: take up the background stage's publication, step the model's
//                    force stage, make the force safe, fill the preallocated row. No
//                    locks, no allocation, no I/O, no exceptions after start.
//   background       BackgroundStage::run_realtime: bounded slices of work, sleeping while
//                    there is none (the voxel model: relaxation slices publishing into a
//                    DoubleBufferedField, waking on the force thread's next change).
//   calling thread   drains the force thread's rows from a fixed ring (8 s of rows) into
//                    the session and the summary, ~10 times a second, and reports
//                    progress: memory stays flat however long the session runs, and the
//                    session file is flushed every second (haptics/session.h).

#include <atomic>
#include <cstdint>
#include <functional>

#include <string>
#include <vector>

#include "haptics/render_feed.h"
#include "haptics/replay.h"
#include "haptics/scheduler.h"

namespace hapvox::haptics {

/// The watchdog's default threshold, ms late (docs/realtime.md, "The watchdog").
inline constexpr double kDefaultWatchdogMs = 4.0;

struct TimingSummary {
  double rate_hz = 0;  // target
  // Force thread. Lateness = actual start - scheduled start of a tick.
  DurationStats lateness;
  std::size_t missed_deadlines = 0;         // ticks that ended after the next tick's deadline
  double watchdog_ms = 0;                   // the watchdog's threshold this run used
  std::size_t watchdog_trips = 0;           // ticks that overran the watchdog (each starts a ramp)
  std::uint64_t watchdog_ramped_ticks = 0;  // ticks sent ramped down (factor < 1) by trips
  double achieved_rate_hz = 0;
  double wall_time_s = 0;
  double force_cpu_s = 0;               // force thread CPU time over the loop
  long force_involuntary_switches = 0;  // times the kernel preempted the force thread
  std::size_t stalled_ticks = 0;        // started more than a full period late
  std::uint64_t rows_dropped = 0;       // rows the session writer fell 8 s behind on (lost)
  double machine_steal_s = 0;           // hypervisor steal time, all CPUs, over the run
  SchedulerReport scheduler;
  // Background thread (the voxel model: one slice = apply queued deletions, relax a
  // budget, publish).
  DurationStats relax_slice;
  double relax_busy_fraction = 0;  // time in slices / wall time
  double relax_cpu_s = 0;
  /// Paced lockstep: how often the background thread stepped down from SCHED_FIFO to stay
  /// under the kernel's real-time budget (over 75 % busy for 200 ms).
  std::size_t relax_fifo_demotions = 0;
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
  /// A tick that ends more than `watchdog_ms` after its deadline counts a watchdog trip:
  /// its own (late but fresh) force is sent, and from the next tick on the force is ramped
  /// down to zero and back in at the ramp-in's slope (ForceRamp), never stepped. A tick
  /// less late than that sends its force at full scale: the device holds the last force
  /// meanwhile, as its servo does between commands. Why 4 ms: docs/realtime.md, "The
  /// watchdog".
  double watchdog_ms = kDefaultWatchdogMs;
  /// > 0: the threshold in device periods instead (--watchdog-periods), at any rate.
  double watchdog_periods = 0.0;
  ForceThreadHooks hooks;
  /// Set by the application (a signal handler, a window's close) to end the loop after the
  /// tick under way; the session keeps every tick run. Null: runs to the device's end.
  const std::atomic<bool>* stop = nullptr;
  /// With a loop, a third thread renders: it is fed the force thread's tool pose and the
  /// relaxation thread's changed voxels (haptics/render_feed.h), never blocking either.
  RenderLoop render_loop;
  /// Paced lockstep: the background stage does its lockstep work for tick k
  /// (BackgroundStage::run_lockstep_tick, on a stage made for lockstep) on its thread while
  /// the force thread waits for tick k+1's deadline, and tick k+1's force stage starts once
  /// it is done. The run is then the lockstep replay of the positions the device gave, bit
  /// for bit, paced by the clock: what may differ is when ticks ran (a tick whose
  /// background work ran past the next deadline starts late, and a watchdog trip ramps the
  /// force sent), never what they computed. The force thread still allocates nothing and
  /// takes no lock; the waiting is a spin on an atomic.
  bool background_in_lockstep = false;
};

/// Replays `device` in realtime through a model's stages. With a `background` stage, it
/// runs on a second thread (BackgroundStage::run_realtime), fed by the force stage's
/// hand-offs and publishing back to it; `sculpt_summary` (if not null) gets what it did.
ReplaySummary replay_realtime(ForceStage& force, BackgroundStage* background, Device& device,
                              const DeviceLimits& limits, SessionWriter* session,
                              const ProgressFn& progress, SculptSummary* sculpt_summary,
                              TimingSummary* timing, const RealtimeOptions& options = {});

}  // namespace hapvox::haptics
