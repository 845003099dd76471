#include "haptics/voxel_model.h"

#include <algorithm>
#include <chrono>
#include <thread>

#include "engine/check.h"
#include "haptics/elapsed_ns.h"
#include "haptics/scheduler.h"

namespace hapvox::haptics {
namespace {

using Clock = std::chrono::steady_clock;

engine::ToolForceState make_force_state(const engine::ToolForceModel& model,
                                        DoubleBufferedField* buffers) {
  if (buffers == nullptr) return model.make_state();
  HAPVOX_CHECK(&model.field() == &buffers->buffer(0));
  return model.make_state(buffers->buffer(1));
}

}  // namespace

// --- Force stage ---

VoxelForceStage::VoxelForceStage(const engine::ToolForceModel& model, SurfaceChangeChannel* channel,
                                 DoubleBufferedField* buffers)
    : model_(model),
      channel_(channel),
      buffers_(buffers),
      state_(make_force_state(model, buffers)) {}

void VoxelForceStage::acquire_published() noexcept {
  if (buffers_ == nullptr) return;
  const int index = buffers_->acquire_for_reading();
  state_.read_from(index);
  published_event_ = buffers_->published_event(index);
}

Vec3d VoxelForceStage::step(const Vec3d& tool_center_mm, TickRecord& row) noexcept {
  model_.step(tool_center_mm, state_);
  row.displacement_mm = state_.displacement_mm;
  row.contact_area_mm2 = state_.contact.contact_area_mm2;
  row.contact = state_.in_contact ? 1 : 0;
  row.strain = state_.strain;
  row.stress_measure_pa = state_.stress_measure_pa;
  row.zone = static_cast<std::uint8_t>(state_.zone);
  row.plastic_event = state_.surface_change_emitted ? 1 : 0;
  row.published_event = published_event_;
  if (channel_ != nullptr) {
    if (state_.surface_change_emitted) {
      engine::SurfaceChange change = state_.surface_change;
      change.event = events_emitted_++;
      channel_->push(change);
    } else {
      channel_->flush();
    }
    row.queue_depth = channel_->depth();
  }
  return state_.force_n;
}

bool VoxelForceStage::flush_handoffs() noexcept { return channel_ == nullptr || channel_->flush(); }

ForceStageCounters VoxelForceStage::counters() const noexcept {
  return ForceStageCounters{state_.contact_onsets, state_.nonfinite_forces};
}

void VoxelForceStage::write_attributes(SessionWriter& session) const {
  const engine::ToolForceOptions& o = model_.options();
  session.set_attribute("model", std::string("voxel"));
  session.set_attribute("youngs_modulus_pa", o.material.youngs_modulus_pa);
  session.set_attribute("poisson_ratio", o.material.poisson_ratio);
  session.set_attribute("lame_lambda_pa", model_.lame().lambda_pa);
  session.set_attribute("lame_mu_pa", model_.lame().mu_pa);
  session.set_attribute("tool_diameter_mm", o.tool.diameter_mm);
  session.set_attribute("contact_law", std::string(engine::contact_law_name(o.contact_law)));
  session.set_attribute("reference_length_mm", model_.fixed_reference_length_mm());
  session.set_attribute("surface_density", o.surface_density);
  session.set_attribute("friction_coefficient", o.friction_coefficient);
  session.set_attribute("surface_samples", std::int64_t{model_.surface_sample_count()});
}

// --- Relaxation ---

RelaxStageWork run_relax_stage(engine::MassGrid& mass, SurfaceChangeChannel& channel,
                               std::size_t max_deletions, std::size_t relax_budget) {
  RelaxStageWork work;
  engine::SurfaceChange change;
  while (work.deletions < max_deletions && channel.pop(change)) {
    mass.apply_deletion(change);
    ++work.deletions;
    work.newest_event = std::max(work.newest_event, change.event);
  }
  work.relax_steps = mass.relax(relax_budget);
  return work;
}

std::int64_t drain_relaxation(engine::MassGrid& mass, SurfaceChangeChannel& channel) {
  engine::SurfaceChange change;
  std::int64_t newest_event = -1;
  while (channel.pop(change)) {
    mass.apply_deletion(change);
    newest_event = std::max(newest_event, change.event);
  }
  mass.finish_flows();
  return newest_event;
}

RelaxationStage::RelaxationStage(engine::MassGrid& mass, SurfaceChangeChannel& channel,
                                 engine::DensityField& mirror, VoxelForceStage& force,
                                 const RelaxBudget& budget)
    : mass_(mass), channel_(channel), mirror_(&mirror), force_(&force), budget_(budget) {
  HAPVOX_CHECK(&force.model().field() == &mirror);
}

RelaxationStage::RelaxationStage(engine::MassGrid& mass, SurfaceChangeChannel& channel,
                                 DoubleBufferedField& buffers, const RelaxBudget& budget)
    : mass_(mass), channel_(channel), buffers_(&buffers), budget_(budget) {}

void RelaxationStage::begin() {
  // A stage may run more than once: the per-row deltas start from this run's totals.
  deleted_seen_ = mass_.work().deleted_voxels;
  relaxed_seen_ = mass_.work().relaxed_voxels;
  deleted_.store(deleted_seen_, std::memory_order_relaxed);
  relaxed_.store(relaxed_seen_, std::memory_order_relaxed);
  initial_mass_units_ = mass_.summed_mass_units();
  mass_units_ = initial_mass_units_;
  published_mass_units_.store(initial_mass_units_, std::memory_order_relaxed);
}

std::size_t RelaxationStage::publish_lockstep(const LockstepRender* render) {
  if (render == nullptr || !render->voxel_changed) return mass_.publish_changes(*mirror_);
  mass_.take_changes(changed_);
  auto out = mirror_->mutable_grid().getAccessor();
  for (const openvdb::Coord& ijk : changed_) {
    const float rho = mass_.density(ijk);
    if (rho == 0.0f) {
      out.setValueOff(ijk, 0.0f);
    } else {
      out.setValueOn(ijk, rho);
    }
    render->voxel_changed(ijk, rho);
  }
  return changed_.size();
}

void RelaxationStage::run_lockstep_tick(std::size_t tick, TickRecord& row,
                                        const LockstepRender* render) {
  HAPVOX_CHECK(mirror_ != nullptr);
  // Deletions first (highest priority), then a fixed budget.
  const engine::RelaxWork before = mass_.work();
  const RelaxStageWork work =
      run_relax_stage(mass_, channel_, budget_.max_deletions, budget_.relax_voxels);
  if (publish_lockstep(render) > 0) force_->state().invalidate_cache();
  applied_event_ = std::max(applied_event_, work.newest_event);
  force_->note_published(applied_event_);
  row.deleted_voxels =
      static_cast<std::int64_t>(mass_.work().deleted_voxels - before.deleted_voxels);
  row.relaxed_voxels =
      static_cast<std::int64_t>(mass_.work().relaxed_voxels - before.relaxed_voxels);
  if (budget_.mass_every_ticks > 0 && tick % budget_.mass_every_ticks == 0) {
    mass_units_ = mass_.total_mass_units();
  }
  row.total_mass_units = mass_units_;
}

// Realtime: the queued changes as sweeps (SweepMerger), deletions first.
RelaxStageWork RelaxationStage::apply_queued_sweeps() {
  RelaxStageWork work;
  engine::SurfaceChange sweep;
  while (work.deletions < budget_.max_deletions && merger_.next_sweep(channel_, sweep)) {
    mass_.apply_deletion(sweep);
    ++work.deletions;
    work.newest_event = std::max(work.newest_event, sweep.event);
  }
  return work;
}

// Chunks of kRelaxChunk voxels (with their flow visits and stale pops, MassGrid::relax:
// about 1 ms at most on the bench's 512^3 block): a change that arrives meanwhile waits
// at most one chunk for its deletion, not the whole budget.
std::size_t RelaxationStage::relax_until_arrival() {
  constexpr std::size_t kRelaxChunk = 64;
  const std::size_t budget = budget_.relax_voxels;
  std::size_t steps = 0;
  for (std::size_t asked = 0; asked < budget; asked += kRelaxChunk) {
    if (change_waiting()) break;
    const std::size_t did = mass_.relax(std::min(kRelaxChunk, budget - asked));
    if (did == 0) break;
    steps += did;
  }
  return steps;
}

void RelaxationStage::publish_realtime(const std::atomic<bool>& force_done, RenderFeed* feed,
                                       std::vector<openvdb::Coord>& published) {
  buffers_->publish(mass_, force_done, feed != nullptr ? &published : nullptr, applied_event_);
  published_event_ = applied_event_;
}

// It works in bounded slices while there is work (queued deletions, voxels to relax, a
// flow in flight, changes to publish or to hand to the renderer) and sleeps in the
// channel's wait_for_arrival() when there is none: an idle thread costs no CPU and wakes
// on the force thread's next push (or its end), not on a timer. A slice applies the queued
// deletions and publishes them at once (the force thread reads them at its next tick),
// then relaxes until its budget is spent or the next change arrives. What relaxation
// changed goes out with the next deletion while the tool sculpts, and on its own once the
// tool has stopped for kRelaxOnlyAfter (when the reader has left the back buffer: never
// waited for).
void RelaxationStage::run_realtime(const std::atomic<bool>& force_done, Clock::time_point start,
                                   RenderFeed* feed, BackgroundTiming& timing) {
  HAPVOX_CHECK(buffers_ != nullptr);
  const double cpu_start = thread_cpu_s();
  // Relaxation publishes on its own once no deletion has gone out for this long.
  constexpr auto kRelaxOnlyAfter = std::chrono::milliseconds(5);
  std::vector<openvdb::Coord> published;
  auto last_mass = Clock::now();
  auto last_deletion = Clock::now() - kRelaxOnlyAfter;
  bool mass_stale = false;  // work done since the last exact mass measurement
  while (true) {
    // Arrivals before force_done: a push or the end announced after these loads bumps
    // the count, so the wait below returns at once instead of sleeping through it.
    const std::uint32_t arrivals = channel_.arrivals();
    const bool finishing = force_done.load(std::memory_order_acquire);
    const auto slice_begin = Clock::now();
    const RelaxStageWork deleted = apply_queued_sweeps();
    applied_event_ = std::max(applied_event_, deleted.newest_event);
    if (deleted.deletions > 0 || applied_event_ > published_event_) {
      publish_realtime(force_done, feed, published);
      last_deletion = Clock::now();
    }
    const std::size_t relax_steps = relax_until_arrival();
    // While the tool sculpts, relaxation's changes go out with the next deletion's
    // publication: one of their own would take the flip the deletion then waits a tick for.
    const bool sculpting = Clock::now() - last_deletion < kRelaxOnlyAfter;
    if (mass_.has_changes() &&
        (finishing || (!sculpting && !change_waiting() && buffers_->back_is_free()))) {
      publish_realtime(force_done, feed, published);
    }
    timing.slice_max_deletions = std::max(timing.slice_max_deletions, deleted.deletions);
    timing.slice_max_steps = std::max(timing.slice_max_steps, relax_steps);
    const std::size_t did = deleted.deletions + relax_steps;
    mass_stale = mass_stale || did > 0;
    if (feed != nullptr && (!published.empty() || !feed->voxels.drained_backlog())) {
      feed->voxels.offer(published, mass_);
      published.clear();
    }
    deleted_.store(mass_.work().deleted_voxels, std::memory_order_relaxed);
    relaxed_.store(mass_.work().relaxed_voxels, std::memory_order_relaxed);
    // The exact mass (kept by the mass grid) is published every ~50 ms while the grid
    // changes, and once more when it stops.
    const bool idle =
        did == 0 && !mass_.has_changes() && (feed == nullptr || feed->voxels.drained_backlog());
    if (mass_stale && (idle || Clock::now() - last_mass > std::chrono::milliseconds(50))) {
      published_mass_units_.store(mass_.total_mass_units(), std::memory_order_relaxed);
      last_mass = Clock::now();
      mass_stale = false;
    }
    if (did > 0) {
      timing.slice_start_ns.push_back(ns_between(start, slice_begin));
      timing.slice_ns.push_back(ns_between(slice_begin, Clock::now()));
    }
    if (finishing) break;
    if (idle) {
      channel_.wait_for_arrival(arrivals);
    } else if (did == 0) {
      // Waiting on the renderer's queue or the reader's buffer switch: poll gently.
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  }
  timing.cpu_s = thread_cpu_s() - cpu_start;
}

void RelaxationStage::fill_realtime_row(TickRecord& row) noexcept {
  const std::uint64_t deleted = deleted_.load(std::memory_order_relaxed);
  const std::uint64_t relaxed = relaxed_.load(std::memory_order_relaxed);
  row.deleted_voxels = static_cast<std::int64_t>(deleted - deleted_seen_);
  row.relaxed_voxels = static_cast<std::int64_t>(relaxed - relaxed_seen_);
  deleted_seen_ = deleted;
  relaxed_seen_ = relaxed;
  row.total_mass_units = published_mass_units_.load(std::memory_order_relaxed);
}

SculptSummary RelaxationStage::finish(const LockstepRender* render, RenderFeed* feed,
                                      const std::atomic<bool>* render_finished) {
  // What the loop left: changes not yet applied, voxels not yet relaxed.
  SculptSummary summary;
  summary.backlog_changes = channel_.depth();
  summary.backlog_voxels = mass_.queued();
  const auto drain_begin = Clock::now();
  if (merger_.has_carried()) {
    ++summary.backlog_changes;
    engine::SurfaceChange carried;
    merger_.next_sweep(channel_, carried);  // the carried one, and whatever continues it
    mass_.apply_deletion(carried);
    applied_event_ = std::max(applied_event_, carried.event);
  }
  applied_event_ = std::max(applied_event_, drain_relaxation(mass_, channel_));
  summary.drain_s = std::chrono::duration<double>(Clock::now() - drain_begin).count();
  if (mirror_ != nullptr) {
    publish_lockstep(render);
    force_->note_published(applied_event_);
  } else {
    // No reader left: both buffers brought up to date; the render thread (still running)
    // drains the voxel queue, for which this thread is the producer now.
    std::vector<openvdb::Coord> published;
    buffers_->publish_unsynchronized(mass_, feed != nullptr ? &published : nullptr, applied_event_);
    if (feed != nullptr) {
      feed->voxels.offer(published, mass_);
      while (!feed->voxels.drained_backlog() &&
             (render_finished == nullptr || !render_finished->load(std::memory_order_acquire))) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        feed->voxels.offer({}, mass_);
      }
    }
  }
  published_event_ = applied_event_;
  summary.queue_overflows = channel_.overflows();
  summary.deleted_voxels = mass_.work().deleted_voxels;
  summary.relaxed_voxels = mass_.work().relaxed_voxels;
  summary.initial_mass_units = initial_mass_units_;
  summary.final_mass_units = mass_.summed_mass_units();  // counted anew: the real check
  summary.settled = mass_.settled();
  return summary;
}

// --- Entry points ---

ReplaySummary replay_lockstep(const engine::ToolForceModel& model, Device& device,
                              const DeviceLimits& limits, SessionWriter* session,
                              const ProgressFn& progress, SculptContext* sculpt,
                              SculptSummary* sculpt_summary, const LockstepRender* render) {
  if (sculpt == nullptr) {
    VoxelForceStage force(model);
    return replay_lockstep(force, nullptr, device, limits, session, progress, nullptr, render);
  }
  HAPVOX_CHECK(sculpt->mass != nullptr && sculpt->mirror != nullptr && sculpt->channel != nullptr);
  VoxelForceStage force(model, sculpt->channel);
  RelaxationStage relaxation(*sculpt->mass, *sculpt->channel, *sculpt->mirror, force,
                             RelaxBudget{sculpt->relax_voxels_per_tick,
                                         sculpt->max_deletions_per_tick, sculpt->mass_every_ticks});
  return replay_lockstep(force, &relaxation, device, limits, session, progress, sculpt_summary,
                         render);
}

ReplaySummary replay_realtime(const engine::ToolForceModel& model, Device& device,
                              const DeviceLimits& limits, SessionWriter* session,
                              const ProgressFn& progress, RealtimeSculpt* sculpt,
                              SculptSummary* sculpt_summary, TimingSummary* timing,
                              const RealtimeOptions& options) {
  if (sculpt == nullptr) {
    VoxelForceStage force(model);
    return replay_realtime(force, nullptr, device, limits, session, progress, nullptr, timing,
                           options);
  }
  HAPVOX_CHECK(sculpt->mass != nullptr && sculpt->field != nullptr && sculpt->channel != nullptr);
  VoxelForceStage force(model, sculpt->channel, sculpt->field);
  RelaxationStage relaxation(
      *sculpt->mass, *sculpt->channel, *sculpt->field,
      RelaxBudget{sculpt->relax_voxels_per_slice, sculpt->max_deletions_per_slice, 0});
  return replay_realtime(force, &relaxation, device, limits, session, progress, sculpt_summary,
                         timing, options);
}

}  // namespace hapvox::haptics
