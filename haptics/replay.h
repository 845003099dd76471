#pragma once
// Lockstep replay: the force loop driven by a simulated 1 kHz clock. Tick k happens at
// trace time t0 + k / rate; the device position comes from the resampled trace, the force
// from a model's force stage (haptics/model_stages.h), and each tick is recorded. Nothing
// here depends on the wall clock except the per-tick compute time, so two replays give
// identical physics datasets. Nothing here names a concrete model.

#include <cstdint>
#include <functional>
#include <vector>

#include "haptics/device.h"
#include "haptics/model_stages.h"
#include "haptics/replay_summary.h"
#include "haptics/session.h"
#include "haptics/trace.h"
#include "haptics/trace_device.h"

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

  /// The factor for the next tick; call once per tick, in order. `hold_down` (a silent
  /// device, a released dead-man) makes it fall to 0 and stay there while it lasts; it rises
  /// again, at the same slope, once it ends. With no ramp the factor is then 0 at once.
  double next(bool hold_down = false);
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

/// The force stage of tick `tick`, the same code in lockstep and realtime and for every
/// model and device: reads the device, steps the model's force stage, makes the force safe
/// (clamped, then scaled by ramp.next()), fills the row's device and force fields (the
/// stage fills the model's) and sends the force to the device (in its frame). Call it for
/// every tick in order, with one `ramp` per run. Returns true when the model's force was
/// non-finite (sent as zero). Does not allocate, lock or throw; no I/O but the device's own.
bool run_force_stage(ForceStage& stage, Device& device, std::size_t tick,
                     const DeviceLimits& limits, ForceRamp& ramp, TickRecord& row);

/// Called now and then with (ticks done, ticks total).
using ProgressFn = std::function<void(std::size_t, std::size_t)>;

/// Runs every tick of `device` (a device with a known tick count) through `force` on the
/// simulated clock, appending a row per
/// tick to `session` (if not null). Does not close the session.
///
/// With a `background` stage, each tick runs, in this fixed order: the force stage (which
/// may hand a change to the background stage), the background stage's fixed work for one
/// tick (BackgroundStage::run_lockstep_tick, which publishes its results to the force
/// stage and to `render`), and every `render->every_ticks` ticks a frame. After the last
/// tick the background stage finishes its queued work and `sculpt_summary` (if not null)
/// gets what it did. Results are bit-reproducible.
ReplaySummary replay_lockstep(ForceStage& force, BackgroundStage* background, Device& device,
                              const DeviceLimits& limits, SessionWriter* session,
                              const ProgressFn& progress = {},
                              SculptSummary* sculpt_summary = nullptr,
                              const LockstepRender* render = nullptr);

}  // namespace hapvox::haptics
