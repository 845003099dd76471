#include "haptics/replay.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "engine/check.h"

namespace hapvox::haptics {

ReplaySummary replay_lockstep(ForceStage& force, BackgroundStage* background, Device& device,
                              const DeviceLimits& limits, SessionWriter* session,
                              const ProgressFn& progress, SculptSummary* sculpt_summary,
                              const LockstepRender* render) {
  using Clock = std::chrono::steady_clock;
  SummaryBuilder builder(device);
  // A device with a stylus orientation: the session records it per tick.
  if (session != nullptr && device.reports_orientation()) session->record_orientation();
  const std::size_t ticks = device.tick_count();
  HAPVOX_CHECK(ticks != Device::kUnbounded);  // lockstep replays a known trace
  if (ticks == 0) return builder.finish(0, 0);
  double t0 = 0.0;
  ForceSafety safety(limits, device.rate_hz());
  if (background != nullptr) background->begin();
  const std::size_t progress_every = std::max<std::size_t>(1, ticks / 100);

  for (std::size_t tick = 0; tick < ticks; ++tick) {
    TickRecord row;
    const auto start = Clock::now();
    const bool nonfinite = run_force_stage(force, device, tick, limits, safety, row);
    const auto end = Clock::now();
    if (tick == 0) t0 = row.time_s;
    row.scheduled_ns = static_cast<std::int64_t>(std::llround(1e9 * (row.time_s - t0)));
    row.start_ns = row.scheduled_ns;
    if (background != nullptr) background->run_lockstep_tick(tick, row, render);
    row.compute_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(end - start).count();
    builder.add(row, nonfinite);
    if (session != nullptr) session->append(row);
    if (progress && (tick + 1) % progress_every == 0) progress(tick + 1, ticks);
    if (render != nullptr && render->frame && render->every_ticks > 0 &&
        (tick % render->every_ticks == 0 || tick + 1 == ticks)) {
      render->frame(tick, RenderToolState{row.tool_position_mm, row.displacement_mm,
                                          row.contact != 0, static_cast<std::int64_t>(tick)});
    }
  }
  const ForceStageCounters counters = force.counters();
  const ReplaySummary summary = builder.finish(counters.nonfinite_forces, counters.contact_onsets);
  if (background != nullptr) {
    // Whatever the force stage still holds back is handed over and applied.
    force.flush_handoffs();
    SculptSummary sculpted = background->finish(render, nullptr, nullptr);
    sculpted.plastic_events = summary.plastic_events;
    sculpted.max_queue_depth = summary.max_queue_depth;
    if (sculpt_summary != nullptr) *sculpt_summary = sculpted;
  }
  return summary;
}

}  // namespace hapvox::haptics
