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

double ForceRamp::next() {
  if (steps_ == 0.0) {
    level_ = 0;
    return 1.0;
  }
  if (falling_) {
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

double percentile(std::vector<double> values, double pct) {
  if (values.empty()) return 0.0;
  const std::size_t rank = static_cast<std::size_t>(
      std::ceil(std::clamp(pct, 0.0, 100.0) / 100.0 * static_cast<double>(values.size())));
  const std::size_t index = rank == 0 ? 0 : rank - 1;
  std::nth_element(values.begin(), values.begin() + index, values.end());
  return values[index];
}

bool run_force_stage(const engine::ToolForceModel& model, const TraceDevice& device,
                     std::size_t tick, const DeviceLimits& limits, engine::ToolForceState& state,
                     ForceRamp& ramp, SurfaceChangeChannel* channel, TickRecord& row) {
  row.time_s = device.time_s(tick);
  row.device_position_mm = device.device_position_mm(tick);
  row.tool_position_mm = device.tool_position_mm(tick);
  row.holding = device.holding(tick) ? 1 : 0;
  model.step(row.tool_position_mm, state);
  row.force_scale = ramp.next();
  bool clamped = false;
  bool nonfinite = false;
  row.force_n = safe_force(state.force_n, row.force_scale, limits, &clamped, &nonfinite);
  row.clamped = clamped ? 1 : 0;
  row.displacement_mm = state.displacement_mm;
  row.contact_area_mm2 = state.contact.contact_area_mm2;
  row.contact = state.in_contact ? 1 : 0;
  row.strain = state.strain;
  row.stress_measure_pa = state.stress_measure_pa;
  row.zone = static_cast<std::uint8_t>(state.zone);
  row.plastic_event = state.surface_change_emitted ? 1 : 0;
  if (channel != nullptr) {
    if (state.surface_change_emitted) {
      channel->push(state.surface_change);
    } else {
      channel->flush();
    }
    row.queue_depth = channel->depth();
  }
  return nonfinite;
}

RelaxStageWork run_relax_stage(engine::MassGrid& mass, SurfaceChangeChannel& channel,
                               std::size_t max_deletions, std::size_t relax_budget) {
  RelaxStageWork work;
  engine::SurfaceChange change;
  while (work.deletions < max_deletions && channel.pop(change)) {
    mass.apply_deletion(change);
    ++work.deletions;
  }
  work.relax_steps = mass.relax(relax_budget);
  return work;
}

void drain_relaxation(engine::MassGrid& mass, SurfaceChangeChannel& channel) {
  engine::SurfaceChange change;
  while (channel.pop(change)) mass.apply_deletion(change);
  mass.finish_flows();
}

namespace {

// The mass grid's changed voxels into the force model's field and to the renderer.
std::size_t publish(engine::MassGrid& mass, engine::DensityField& mirror,
                    const LockstepRender* render, std::vector<openvdb::Coord>& scratch) {
  if (render == nullptr || !render->voxel_changed) return mass.publish_changes(mirror);
  mass.take_changes(scratch);
  auto out = mirror.mutable_grid().getAccessor();
  for (const openvdb::Coord& ijk : scratch) {
    const float rho = mass.density(ijk);
    if (rho == 0.0f) {
      out.setValueOff(ijk, 0.0f);
    } else {
      out.setValueOn(ijk, rho);
    }
    render->voxel_changed(ijk, rho);
  }
  return scratch.size();
}

}  // namespace

ReplaySummary replay_lockstep(const engine::ToolForceModel& model, const TraceDevice& device,
                              const DeviceLimits& limits, SessionWriter* session,
                              const ProgressFn& progress, SculptContext* sculpt,
                              SculptSummary* sculpt_summary, const LockstepRender* render) {
  using Clock = std::chrono::steady_clock;
  ReplaySummary summary;
  summary.ticks = device.tick_count();
  summary.trace_gaps = device.trace().gap_count;
  summary.trace_held_s = device.trace().held_time_s;
  if (summary.ticks == 0) return summary;
  const double dt_s = 1.0 / device.rate_hz();
  const double t0 = device.time_s(0);
  summary.duration_s = device.time_s(summary.ticks - 1) - t0;

  engine::ToolForceState state = model.make_state();
  ForceRamp ramp(limits, device.rate_hz());
  SculptSummary sculpted;
  std::int64_t mass_units = 0;
  if (sculpt != nullptr) {
    HAPVOX_CHECK(sculpt->mass != nullptr && sculpt->mirror != nullptr &&
                 sculpt->channel != nullptr);
    HAPVOX_CHECK(&model.field() == sculpt->mirror);
    mass_units = sculpt->mass->total_mass_units();
    sculpted.initial_mass_units = mass_units;
  }
  std::vector<double> compute_us(summary.ticks);
  std::vector<openvdb::Coord> changed;
  const std::size_t progress_every = std::max<std::size_t>(1, summary.ticks / 100);

  for (std::size_t tick = 0; tick < summary.ticks; ++tick) {
    TickRecord row;
    row.scheduled_ns = static_cast<std::int64_t>(std::llround(1e9 * (device.time_s(tick) - t0)));
    row.start_ns = row.scheduled_ns;
    const auto start = Clock::now();
    const bool nonfinite = run_force_stage(model, device, tick, limits, state, ramp,
                                           sculpt != nullptr ? sculpt->channel : nullptr, row);
    const auto end = Clock::now();
    if (sculpt != nullptr) {
      sculpted.plastic_events += row.plastic_event;
      sculpted.max_queue_depth = std::max<std::size_t>(sculpted.max_queue_depth, row.queue_depth);
      // Relaxation stage: deletions first (highest priority), then a fixed budget.
      const engine::RelaxWork before = sculpt->mass->work();
      run_relax_stage(*sculpt->mass, *sculpt->channel, sculpt->max_deletions_per_tick,
                      sculpt->relax_voxels_per_tick);
      if (publish(*sculpt->mass, *sculpt->mirror, render, changed) > 0) state.invalidate_cache();
      row.deleted_voxels =
          static_cast<std::int64_t>(sculpt->mass->work().deleted_voxels - before.deleted_voxels);
      row.relaxed_voxels =
          static_cast<std::int64_t>(sculpt->mass->work().relaxed_voxels - before.relaxed_voxels);
      if (sculpt->mass_every_ticks > 0 && tick % sculpt->mass_every_ticks == 0) {
        mass_units = sculpt->mass->total_mass_units();
      }
      row.total_mass_units = mass_units;
    }
    row.compute_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(end - start).count();
    compute_us[tick] = 1e-3 * static_cast<double>(row.compute_ns);

    summary.contact_ticks += row.contact;
    summary.clamped_ticks += row.clamped;
    summary.nonfinite_forces += nonfinite ? 1 : 0;
    summary.peak_force_n = std::max(summary.peak_force_n, row.force_n.norm());
    if (session != nullptr) session->append(row);
    if (progress && (tick + 1) % progress_every == 0) progress(tick + 1, summary.ticks);
    if (render != nullptr && render->frame && render->every_ticks > 0 &&
        (tick % render->every_ticks == 0 || tick + 1 == summary.ticks)) {
      render->frame(tick, RenderToolState{row.tool_position_mm, state.displacement_mm,
                                          state.in_contact, static_cast<std::int64_t>(tick)});
    }
  }
  if (sculpt != nullptr) {
    // Whatever the channel still holds is applied before the summary.
    sculpt->channel->flush();
    drain_relaxation(*sculpt->mass, *sculpt->channel);
    publish(*sculpt->mass, *sculpt->mirror, render, changed);
    sculpted.queue_overflows = sculpt->channel->overflows();
    sculpted.deleted_voxels = sculpt->mass->work().deleted_voxels;
    sculpted.relaxed_voxels = sculpt->mass->work().relaxed_voxels;
    sculpted.final_mass_units = sculpt->mass->total_mass_units();
    sculpted.settled = sculpt->mass->settled();
    if (sculpt_summary != nullptr) *sculpt_summary = sculpted;
  }
  summary.contact_time_s = static_cast<double>(summary.contact_ticks) * dt_s;
  summary.contact_onsets = state.contact_onsets;
  summary.nonfinite_forces += state.nonfinite_forces;
  summary.compute_p50_us = percentile(compute_us, 50.0);
  summary.compute_p99_us = percentile(compute_us, 99.0);
  summary.compute_max_us = *std::max_element(compute_us.begin(), compute_us.end());
  return summary;
}

}  // namespace hapvox::haptics
