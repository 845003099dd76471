#pragma once
// The 1 kHz force loop, three ways:
//   run_lockstep   every tick of a device on a simulated clock: bit-reproducible physics;
//   run_realtime   on a force thread paced by the wall clock (plus a relaxation thread when
//                  sculpting), with timing statistics;
//   ForceStage     one tick per call, from your own loop (your simulator's haptic thread).
// All three run the same force stage: read the device, step the model, make the force safe
// (non-finite -> zero, clamped to max_force_n, scaled by the ramp), send it. For the same
// positions they compute the same forces, bit for bit.

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "hapvox/device.h"
#include "hapvox/model.h"

namespace hapvox {

struct LoopOptions {
  double max_force_n = 10.0;  // --max-force-n: forces are clamped to this magnitude
  double ramp_in_s = 0.1;     // --ramp-in-s: forces scale from 0 to 1 over this time
  /// Where to write the session (HDF5); "" for none.
  std::string session_path;
  // Realtime only. Off by default in an embedding application, which owns its process.
  bool realtime_priority = false;  // ask for SCHED_FIFO on the force thread
  bool lock_memory = false;        // mlockall
  int cpu = -1;                    // pin the force thread to this CPU (-1: do not pin)
};

/// What a run did.
struct RunSummary {
  std::size_t ticks = 0;
  std::size_t contact_ticks = 0;
  double peak_force_n = 0.0;
  std::size_t clamped_ticks = 0;
  std::size_t nonfinite_forces = 0;  // replaced by the last safe force, ramped out and in
  std::size_t motion_faults = 0;     // device samples faster than a hand: not used
  double compute_p50_us = 0.0;       // per-tick compute time
  double compute_p99_us = 0.0;
  double compute_max_us = 0.0;
  // Realtime only (zeros in lockstep).
  double lateness_p99_us = 0.0;  // tick start after its deadline
  std::uint64_t watchdog_trips = 0;
  // Sculpting (zeros otherwise): the clay's mass, in density units, before and after.
  std::int64_t initial_mass_units = 0;
  std::int64_t final_mass_units = 0;
};

/// Runs every tick of `device` through `model` on a simulated clock. Throws InputError on a
/// bad option or a device with no end. The FEM model's first snapshot is made where the
/// device's tick 0 puts the tool (a callback device is asked for it once, before the run).
RunSummary run_lockstep(const Model& model, Device& device, const LoopOptions& options = {});

/// Runs `device` in realtime: each tick at its deadline on a force thread (the calling
/// thread waits). Same physics as run_lockstep; what may differ is when ticks ran.
RunSummary run_realtime(const Model& model, Device& device, const LoopOptions& options = {});

/// The force computed for one tick.
struct ForceTick {
  std::array<double, 3> force_n = {0.0, 0.0, 0.0};           // volume frame, as sent
  std::array<double, 3> force_device_n = {0.0, 0.0, 0.0};    // device frame
  std::array<double, 3> tool_position_mm = {0.0, 0.0, 0.0};  // volume frame
  std::array<double, 3> displacement_mm = {0.0, 0.0, 0.0};   // u = x - x0 of the contact
  double force_scale = 0.0;                                  // the ramp factor
  double contact_area_mm2 = 0.0;
  bool contact = false;
  bool clamped = false;  // limited to max_force_n
  bool fault = false;    // the model's force was not finite: zero was sent
};

/// One tick per call from your own loop, in tick order: tick k is the k-th call. Made once
/// (it allocates here); for an elastic voxel model step() then allocates nothing, takes no
/// lock and throws nothing. After the force, step() runs the tick's background work as a
/// lockstep replay does: a sculpting model's bounded relaxation; the FEM model's FEM step
/// every fem_every_ticks ticks (its first step() makes the FEM stage where the tool is:
/// the first snapshot, and what a grab holds).
class ForceStage {
 public:
  /// `rate_hz` is your loop's rate (it sets the ramp's slope).
  explicit ForceStage(const Model& model, const LoopOptions& options = {}, double rate_hz = 1000.0,
                      const DeviceTransform& transform = {});
  ~ForceStage();
  ForceStage(const ForceStage&) = delete;
  ForceStage& operator=(const ForceStage&) = delete;

  /// The force for the tool at `sample` (device frame).
  ForceTick step(const ToolSample& sample) noexcept;
  /// Ticks stepped so far.
  std::size_t ticks() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hapvox
