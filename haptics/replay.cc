#include "haptics/replay.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "engine/check.h"

namespace hapvox::haptics {

Vec3d safe_force(const Vec3d& raw_n, double ramp, const DeviceLimits& limits, bool* clamped,
                 bool* nonfinite) {
  *clamped = false;
  *nonfinite = !raw_n.allFinite();
  if (*nonfinite) return Vec3d::Zero();
  Vec3d force = raw_n;
  const double magnitude = force.norm();
  if (magnitude > limits.max_force_n) {
    force *= limits.max_force_n / magnitude;
    *clamped = true;
  }
  return std::clamp(ramp, 0.0, 1.0) * force;
}

ForceRamp::ForceRamp(const DeviceLimits& limits, double rate_hz) {
  const double steps = limits.ramp_in_s * rate_hz;
  if (std::isfinite(steps) && steps > 0.0) {
    steps_ = steps;
    top_ = static_cast<std::int64_t>(std::ceil(steps));
  }
}

double ForceRamp::factor() const {
  if (level_ < 0) return 0.0;
  if (steps_ == 0.0) return 1.0;
  return std::min(1.0, static_cast<double>(level_) / steps_);
}

void ForceRamp::trip() {
  ++trips_;
  if (steps_ == 0.0) return;  // no ramp: nothing to fall by
  falling_ = true;
  recovering_ = true;
}

double ForceRamp::next(bool hold_down) {
  if (steps_ == 0.0) {
    level_ = 0;
    return hold_down ? 0.0 : 1.0;
  }
  if (hold_down) {
    level_ = std::max<std::int64_t>(0, level_ - 1);
  } else if (falling_) {
    level_ = std::max<std::int64_t>(0, level_ - 1);
    if (level_ == 0) falling_ = false;  // at zero: rise from the next tick
  } else {
    level_ = std::min(level_ + 1, top_);
  }
  const double f = factor();
  if (recovering_) {
    if (f < 1.0) {
      ++reduced_ticks_;
    } else {
      recovering_ = false;
    }
  }
  return f;
}

bool run_force_stage(ForceStage& stage, Device& device, std::size_t tick,
                     const DeviceLimits& limits, ForceRamp& ramp, TickRecord& row) {
  DeviceReading reading;
  device.read(tick, reading);
  const DeviceTransform& transform = device.transform();
  row.time_s = reading.time_s;
  row.device_position_mm = reading.position_mm;
  row.device_orientation_wxyz = reading.orientation_wxyz;
  row.tool_position_mm = transform.apply(reading.position_mm);
  row.holding = reading.holding ? 1 : 0;
  row.device_sequence = reading.sequence;
  const Vec3d model_force_n = stage.step(row.tool_position_mm, row);
  row.force_scale = ramp.next(reading.silent || reading.released);
  bool clamped = false;
  bool nonfinite = false;
  row.force_n = safe_force(model_force_n, row.force_scale, limits, &clamped, &nonfinite);
  row.clamped = clamped ? 1 : 0;
  // Forces go back to the device in its own frame (the scale moves points, not newtons).
  device.send(tick, transform.rotation.transpose() * row.force_n, row, nonfinite);
  return nonfinite;
}

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
  ForceRamp ramp(limits, device.rate_hz());
  if (background != nullptr) background->begin();
  const std::size_t progress_every = std::max<std::size_t>(1, ticks / 100);

  for (std::size_t tick = 0; tick < ticks; ++tick) {
    TickRecord row;
    const auto start = Clock::now();
    const bool nonfinite = run_force_stage(force, device, tick, limits, ramp, row);
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
