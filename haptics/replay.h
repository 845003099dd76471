#pragma once
// Lockstep replay: the force loop driven by a simulated 1 kHz clock. Tick k happens at
// trace time t0 + k / rate; the device position comes from the resampled trace, the force
// from the engine, and each tick is recorded. Nothing here depends on the wall clock
// except the per-tick compute time, so two replays give identical physics datasets.

#include <cstdint>
#include <functional>
#include <vector>

#include "engine/relax.h"
#include "engine/tool_force.h"
#include "haptics/render_feed.h"
#include "haptics/session.h"
#include "haptics/surface_channel.h"
#include "haptics/trace.h"

namespace hapvox::haptics {

/// The haptic device's safety envelope.
struct DeviceLimits {
  double max_force_n = 10.0;  // forces are clamped to this magnitude, direction kept
  double ramp_in_s = 0.1;     // forces scale linearly from 0 to 1 over the first ramp_in_s
};

/// Makes a raw model force safe to send: non-finite -> zero (counted by the caller via
/// `nonfinite`), magnitude clamped to max_force_n (direction kept), then scaled by `ramp`
/// in [0, 1]. Clamped before it is ramped, so a ramp step changes the force by at most
/// max_force_n times the step, however large the raw force.
Vec3d safe_force(const Vec3d& raw_n, double ramp, const DeviceLimits& limits, bool* clamped,
                 bool* nonfinite);

/// The factor every force is sent with, over time: the force stage's own state besides the
/// model's (plain values, no allocation), the same in lockstep and realtime.
///   - ramp-in: 0 on the first tick, rising by 1 / (ramp_in_s * rate) per tick to 1;
///   - after a watchdog trip (trip()): from the next tick on it falls by the same step to
///     0, then rises back to 1; a trip while it rises makes it fall again.
/// So the force sent never steps: tick to tick it changes by at most
/// max_force_n / (ramp_in_s * rate) plus the model's own (clamped) change. With
/// ramp_in_s = 0 there is no ramp: the factor is always 1 and trips are only counted.
class ForceRamp {
 public:
  ForceRamp(const DeviceLimits& limits, double rate_hz);

  /// The factor for the next tick; call once per tick, in order.
  double next();
  /// A watchdog trip: the factor falls to 0 from the next tick on, then rises again.
  void trip();

  /// The factor of the last tick (0 before the first).
  double factor() const;
  /// Largest change of the factor from one tick to the next: 1 / (ramp_in_s * rate).
  double step() const { return steps_ > 0.0 ? 1.0 / steps_ : 1.0; }
  bool falling() const { return falling_; }
  std::uint64_t trips() const { return trips_; }
  /// Ticks sent with the factor held below 1 by a trip (not counting the ramp-in).
  std::uint64_t reduced_ticks() const { return reduced_ticks_; }

 private:
  double steps_ = 0.0;       // ticks from 0 to 1 (ramp_in_s * rate); 0: no ramp
  std::int64_t top_ = 0;     // the level at which the factor reaches 1
  std::int64_t level_ = -1;  // factor = min(1, level / steps)
  bool falling_ = false;
  bool recovering_ = false;  // after a trip, until the factor is back at 1
  std::uint64_t trips_ = 0;
  std::uint64_t reduced_ticks_ = 0;
};

/// A simulated haptic device that replays a resampled trace through a device-to-volume
/// transform: the tool position at tick k.
class TraceDevice {
 public:
  TraceDevice(ResampledTrace trace, const DeviceTransform& transform)
      : trace_(std::move(trace)), transform_(transform) {}

  std::size_t tick_count() const { return trace_.time_s.size(); }
  double rate_hz() const { return trace_.rate_hz; }
  double time_s(std::size_t tick) const { return trace_.time_s[tick]; }
  const Vec3d& device_position_mm(std::size_t tick) const { return trace_.position_mm[tick]; }
  Vec3d tool_position_mm(std::size_t tick) const {
    return transform_.apply(trace_.position_mm[tick]);
  }
  bool holding(std::size_t tick) const { return trace_.holding[tick] != 0; }
  const ResampledTrace& trace() const { return trace_; }
  const DeviceTransform& transform() const { return transform_; }

 private:
  ResampledTrace trace_;
  DeviceTransform transform_;
};

struct ReplaySummary {
  std::size_t ticks = 0;
  std::size_t contact_ticks = 0;
  double contact_time_s = 0.0;
  double duration_s = 0.0;
  double peak_force_n = 0.0;
  std::size_t clamped_ticks = 0;
  std::size_t nonfinite_forces = 0;
  std::uint64_t contact_onsets = 0;
  int trace_gaps = 0;
  double trace_held_s = 0.0;
  // Per-tick compute time (wall clock), microseconds.
  double compute_p50_us = 0.0;
  double compute_p99_us = 0.0;
  double compute_max_us = 0.0;
};

/// What a sculpting (plastic) replay needs besides the force model: the relaxation's mass
/// grid, the float field the force model reads (updated from the mass grid after each
/// relaxation stage), the channel between the two, and the fixed per-tick budget.
struct SculptContext {
  engine::MassGrid* mass = nullptr;
  engine::DensityField* mirror = nullptr;
  SurfaceChangeChannel* channel = nullptr;
  std::size_t relax_voxels_per_tick = 2000;  // relaxation steps per tick (MassGrid::relax)
  std::size_t max_deletions_per_tick = 8;    // queued surface changes applied per tick
  std::size_t mass_every_ticks = 10;         // exact total mass measured every N ticks
};

struct SculptSummary {
  std::uint64_t plastic_events = 0;
  std::uint64_t queue_overflows = 0;
  std::uint64_t deleted_voxels = 0;
  std::uint64_t relaxed_voxels = 0;
  std::int64_t initial_mass_units = 0;
  std::int64_t final_mass_units = 0;
  std::size_t max_queue_depth = 0;
  bool settled = false;
};

/// The force stage of tick `tick`, the same code in lockstep and realtime: reads the
/// device, steps the model, makes the force safe (clamped, then scaled by ramp.next()),
/// and fills the row's device, force and plasticity fields. Call it for every tick in
/// order, with one `ramp` per run. With a channel, hands a surface change to it (or flushes
/// a coalesced one) and records the queue depth. Returns true when the model's force was
/// non-finite (sent as zero). Does not allocate, lock, throw or do I/O.
bool run_force_stage(const engine::ToolForceModel& model, const TraceDevice& device,
                     std::size_t tick, const DeviceLimits& limits, engine::ToolForceState& state,
                     ForceRamp& ramp, SurfaceChangeChannel* channel, TickRecord& row);

/// What one relaxation stage did.
struct RelaxStageWork {
  std::size_t deletions = 0;    // surface changes applied
  std::size_t relax_steps = 0;  // MassGrid::relax steps
};

/// The relaxation stage of one lockstep tick or one realtime slice, the same code in both,
/// with bounded work so the relaxation stays responsive: at most `max_deletions` queued
/// surface changes applied (highest priority; the rest wait in the channel for the next
/// stage), then at most `relax_budget` relaxation steps.
RelaxStageWork run_relax_stage(engine::MassGrid& mass, SurfaceChangeChannel& channel,
                               std::size_t max_deletions, std::size_t relax_budget);

/// The end of a sculpting run (no reader left): applies every change still queued and
/// finishes the flows, so the grid holds all the mass.
void drain_relaxation(engine::MassGrid& mass, SurfaceChangeChannel& channel);

/// Called now and then with (ticks done, ticks total).
using ProgressFn = std::function<void(std::size_t, std::size_t)>;

/// Runs every tick of `device` through `model` on the simulated clock, appending a row per
/// tick to `session` (if not null). Does not close the session.
///
/// With `sculpt`, each tick runs, in this fixed order: the force stage (which may emit a
/// surface change into the channel), the relaxation stage (run_relax_stage: at most
/// max_deletions_per_tick queued deletions, then at most relax_voxels_per_tick relaxation
/// steps), and the publication of changed voxels into
/// the field the force model reads. Results are bit-reproducible.
/// Lockstep rendering: `frame` is called every `every_ticks` ticks (and after the last)
/// with the tool pose of that tick; `voxel_changed` for every voxel the relaxation changed,
/// as it is published to the force model's field, so a renderer's copy stays in step.
struct LockstepRender {
  std::size_t every_ticks = 100;
  std::function<void(std::size_t tick, const RenderToolState& tool)> frame;
  std::function<void(const openvdb::Coord& ijk, float density)> voxel_changed;
};

ReplaySummary replay_lockstep(const engine::ToolForceModel& model, const TraceDevice& device,
                              const DeviceLimits& limits, SessionWriter* session,
                              const ProgressFn& progress = {}, SculptContext* sculpt = nullptr,
                              SculptSummary* sculpt_summary = nullptr,
                              const LockstepRender* render = nullptr);

/// Percentile (0..100) of a sample by nearest rank; 0 for an empty sample.
double percentile(std::vector<double> values, double pct);

}  // namespace hapvox::haptics
