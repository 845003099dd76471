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
#include "haptics/force_safety.h"
#include "haptics/model_stages.h"
#include "haptics/replay_summary.h"
#include "haptics/session.h"
#include "haptics/trace.h"
#include "haptics/trace_device.h"

namespace hapvox::haptics {

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
