#pragma once
// The force stage of one tick (run_force_stage), the same for every loop, model and device,
// and its own safety state (DESIGN.md, Haptic safety): the device's limits, the clamp, the
// ramp that takes the force out and back in after a fault, and the guard that tells a
// position a hand could have reached from a sample that jumped. Plain values, no
// allocation: one ForceSafety per run, on the force thread.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>

#include "haptics/device.h"
#include "haptics/model_stages.h"

namespace hapvox::haptics {

using Vec3d = Eigen::Vector3d;

/// The haptic device's safety envelope.
struct DeviceLimits {
  double max_force_n = 10.0;  // forces are clamped to this magnitude, direction kept
  double ramp_in_s = 0.1;     // forces scale linearly from 0 to 1 over the first ramp_in_s
  // Motion a hand on a device can make (MotionGuard): a sample that moves the device point
  // faster than this from the last one used is a fault, not a position. 10 m/s is several
  // times the fastest hand motion on a desktop device (~2 m/s in a flick).
  double max_speed_mm_s = 10000.0;
  // How far from the device origin a sample may lie (device frame): 10 m, beyond any
  // device's workspace. A farther sample is a fault.
  double max_reach_mm = 10000.0;
};

/// Makes a raw model force safe to send: non-finite -> zero (counted by the caller via
/// `nonfinite`), magnitude clamped to max_force_n (direction kept), then scaled by `ramp`
/// in [0, 1]. Clamped before it is ramped, so a ramp step changes the force by at most
/// max_force_n times the step, however large the raw force. The magnitude is measured
/// without overflow: a force of 1e170 N per axis is clamped, not lost to an infinite |F|.
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

/// Judges each device sample against what a hand can do. A sample is a motion fault when it
/// is not finite, lies beyond max_reach_mm of the device origin, or lies farther than
/// max_speed_mm_s allows both from the last position used (the allowance grows with the ticks
/// since) and from the previous sample. The second test lets the device relocate: after one
/// faulted jump, a sample that follows on from it is a position again. A lone spike (x = 1e9
/// for one row) is thus one or two faults, and the model never sees it.
class MotionGuard {
 public:
  MotionGuard(const DeviceLimits& limits, double rate_hz);

  /// The position the model is to use this tick: `sample_mm`, or the last one used when the
  /// sample is a fault (then returns true and counts it).
  bool judge(const Vec3d& sample_mm, Vec3d& used_mm);

  std::uint64_t faults() const { return faults_; }
  /// Largest move between two ticks a hand can make: max_speed_mm_s / rate.
  double max_step_mm() const { return max_step_mm_; }

 private:
  bool within_reach(const Vec3d& sample_mm) const;

  double max_step_mm_ = 0.0;
  double max_reach_mm_ = 0.0;
  Vec3d last_used_mm_ = Vec3d::Zero();
  Vec3d last_sample_mm_ = Vec3d::Zero();
  bool have_used_ = false;
  bool last_sample_in_reach_ = false;
  std::uint64_t ticks_since_used_ = 0;
  std::uint64_t faults_ = 0;
};

/// Everything the force stage keeps between ticks besides the model: one per run. A fault
/// (a motion fault: MotionGuard keeps the model at the last position used; a non-finite
/// model force) trips the ramp, and while the ramp falls the last safe force is sent,
/// scaled down at the ramp's slope; the model's force comes back in from zero. So a fault
/// never steps the force, whatever the model does meanwhile (a relocated tool may press
/// somewhere else).
struct ForceSafety {
  ForceSafety(const DeviceLimits& limits, double rate_hz)
      : ramp(limits, rate_hz), motion(limits, rate_hz) {}
  void fault() {
    ramp.trip();
    holding_force = true;
  }
  ForceRamp ramp;
  MotionGuard motion;
  Vec3d last_safe_force_n = Vec3d::Zero();  // clamped, before the ramp
  bool holding_force = false;               // falling after a fault: send last_safe_force_n
};

/// The force stage of tick `tick`, the same code in lockstep and realtime and for every
/// model and device: reads the device, judges its sample (a motion fault keeps the model at
/// the last position used and trips the ramp), steps the model's force stage, makes the
/// force safe (clamped; a non-finite one replaced by the last safe force, tripping the ramp;
/// then scaled by the ramp), fills the row's device and force fields (the stage fills the
/// model's) and sends the force to the device (in its frame). Call it for every tick in
/// order, with one `safety` per run. Returns true when the model's force was non-finite.
/// Does not allocate, lock or throw; no I/O but the device's own.
bool run_force_stage(ForceStage& stage, Device& device, std::size_t tick,
                     const DeviceLimits& limits, ForceSafety& safety, TickRecord& row);

}  // namespace hapvox::haptics
