#pragma once
// The voxel model (Prados et al.: elastic and plastic tool force from a density field,
// deletion and progressive relaxation) behind the seams of haptics/model_stages.h:
//
//   VoxelForceStage   engine::ToolForceModel and its per-thread state; a plastic step's
//                     SurfaceChange goes into a SurfaceChangeChannel (lock-free SPSC)
//   RelaxationStage   engine::MassGrid: queued deletions first, then a bounded relaxation
//                     budget, the changed voxels published into the field the force stage
//                     reads (lockstep: that field itself; realtime: a DoubleBufferedField)
//                     and to the renderer
//
// and the replay entry points that build both from the pieces (the CLI and tests).

#include <atomic>
#include <cstdint>
#include <vector>

#include "engine/relax.h"
#include "engine/tool_force.h"
#include "haptics/double_buffered_field.h"
#include "haptics/model_stages.h"
#include "haptics/realtime.h"
#include "haptics/replay.h"
#include "haptics/surface_channel.h"
#include "haptics/sweep_merger.h"

namespace hapvox::haptics {

/// The voxel model's 1 kHz stage.
class VoxelForceStage final : public ForceStage {
 public:
  /// Reads `model.field()`; with `buffers` (whose buffer 0 must be model.field()) it reads
  /// the buffer the relaxation published last. With `channel`, plastic steps are handed to
  /// it (a coalesced change waits in the channel until flush_handoffs()).
  explicit VoxelForceStage(const engine::ToolForceModel& model,
                           SurfaceChangeChannel* channel = nullptr,
                           DoubleBufferedField* buffers = nullptr);

  void acquire_published() noexcept override;
  Vec3d step(const Vec3d& tool_center_mm, TickRecord& row) noexcept override;
  bool flush_handoffs() noexcept override;
  ForceStageCounters counters() const noexcept override;
  /// model = "voxel", E, nu, Lame, tool diameter, contact law, L, surface density, slip.
  void write_attributes(SessionWriter& session) const override;

  engine::ToolForceState& state() { return state_; }
  const engine::ToolForceModel& model() const { return model_; }
  /// Lockstep: the field this stage reads has taken in plastic events up to `event` (the
  /// relaxation stage says so after publishing; realtime reads it with the buffer).
  void note_published(std::int64_t event) noexcept { published_event_ = event; }

 private:
  const engine::ToolForceModel& model_;
  SurfaceChangeChannel* channel_;
  DoubleBufferedField* buffers_;
  engine::ToolForceState state_;
  std::int64_t events_emitted_ = 0;    // plastic events so far (numbers the hand-offs)
  std::int64_t published_event_ = -1;  // the newest the field read has taken in
};

/// What one relaxation stage did.
struct RelaxStageWork {
  std::size_t deletions = 0;       // surface changes applied (realtime: merged sweeps)
  std::size_t relax_steps = 0;     // MassGrid::relax steps
  std::int64_t newest_event = -1;  // the newest SurfaceChange::event applied; -1: none
};

/// The relaxation stage of one lockstep tick, with bounded work: at most `max_deletions`
/// queued surface changes applied (highest priority; the rest wait in the channel for the
/// next stage), then at most `relax_budget` relaxation steps. (A realtime slice does the
/// same work in its own order: RelaxationStage::run_realtime.)
RelaxStageWork run_relax_stage(engine::MassGrid& mass, SurfaceChangeChannel& channel,
                               std::size_t max_deletions, std::size_t relax_budget);

/// The end of a sculpting run (no reader left): applies every change still queued and
/// finishes the flows, so the grid holds all the mass. Returns the newest event applied
/// (-1: none was queued).
std::int64_t drain_relaxation(engine::MassGrid& mass, SurfaceChangeChannel& channel);

/// A relaxation stage's fixed budget.
struct RelaxBudget {
  std::size_t relax_voxels = 2000;    // relaxation steps per tick or slice (MassGrid::relax)
  std::size_t max_deletions = 8;      // queued surface changes applied per tick or slice
  std::size_t mass_every_ticks = 10;  // lockstep: exact total mass measured every N ticks
};

/// The voxel model's background stage: the relaxation.
class RelaxationStage final : public BackgroundStage {
 public:
  /// Lockstep: publishes into `mirror`, the field `force` reads (its cache is invalidated
  /// after each publication).
  RelaxationStage(engine::MassGrid& mass, SurfaceChangeChannel& channel,
                  engine::DensityField& mirror, VoxelForceStage& force, const RelaxBudget& budget);
  /// Realtime: publishes into the back buffer of `buffers`.
  RelaxationStage(engine::MassGrid& mass, SurfaceChangeChannel& channel,
                  DoubleBufferedField& buffers, const RelaxBudget& budget);

  void begin() override;
  void run_lockstep_tick(std::size_t tick, TickRecord& row, const LockstepRender* render) override;
  void run_realtime(const std::atomic<bool>& force_done,
                    std::chrono::steady_clock::time_point start, RenderFeed* feed,
                    BackgroundTiming& timing) override;
  void fill_realtime_row(TickRecord& row) noexcept override;
  void wake() noexcept override { channel_.wake(); }
  SculptSummary finish(const LockstepRender* render, RenderFeed* feed,
                       const std::atomic<bool>* render_finished) override;

 private:
  // Lockstep: the mass grid's changed voxels into the mirror and to the renderer.
  std::size_t publish_lockstep(const LockstepRender* render);
  // Realtime: at most max_deletions sweeps of the queued changes (SweepMerger), applied.
  RelaxStageWork apply_queued_sweeps();
  // Realtime: a surface change waits, queued or carried by the merger.
  bool change_waiting() const { return channel_.depth() > 0 || merger_.has_carried(); }
  // Realtime: relaxation in chunks, up to the budget, until a change arrives. Steps taken
  // (MassGrid::relax's count).
  std::size_t relax_until_arrival();
  // Realtime: the grid's changes into the back buffer, made the front.
  void publish_realtime(const std::atomic<bool>& force_done, RenderFeed* feed,
                        std::vector<openvdb::Coord>& published);

  engine::MassGrid& mass_;
  SurfaceChangeChannel& channel_;
  engine::DensityField* mirror_ = nullptr;  // lockstep
  VoxelForceStage* force_ = nullptr;        // lockstep
  DoubleBufferedField* buffers_ = nullptr;  // realtime
  RelaxBudget budget_;
  std::int64_t initial_mass_units_ = 0;
  std::int64_t mass_units_ = 0;        // lockstep: the last exact measurement
  std::int64_t applied_event_ = -1;    // the newest plastic event the mass grid took in
  std::int64_t published_event_ = -1;  // the newest the force stage's field has
  std::vector<openvdb::Coord> changed_;
  SweepMerger merger_;  // realtime
  // Realtime: totals the background thread publishes for the force thread's rows, and
  // the force thread's own last readings of them.
  std::atomic<std::uint64_t> deleted_{0};
  std::atomic<std::uint64_t> relaxed_{0};
  std::atomic<std::int64_t> published_mass_units_{0};
  std::uint64_t deleted_seen_ = 0;  // force thread only
  std::uint64_t relaxed_seen_ = 0;  // force thread only
};

/// What a lockstep sculpting (plastic) replay needs besides the force model: the
/// relaxation's mass grid, the float field the force model reads (updated from the mass
/// grid after each relaxation stage), the channel between the two, and the budget.
struct SculptContext {
  engine::MassGrid* mass = nullptr;
  engine::DensityField* mirror = nullptr;
  SurfaceChangeChannel* channel = nullptr;
  std::size_t relax_voxels_per_tick = 2000;  // relaxation steps per tick (MassGrid::relax)
  std::size_t max_deletions_per_tick = 8;    // queued surface changes applied per tick
  std::size_t mass_every_ticks = 10;         // exact total mass measured every N ticks
};

/// The same for a realtime sculpting replay: the model must read field->buffer(0).
struct RealtimeSculpt {
  engine::MassGrid* mass = nullptr;
  DoubleBufferedField* field = nullptr;
  SurfaceChangeChannel* channel = nullptr;
  std::size_t relax_voxels_per_slice = 2000;  // relaxation steps per slice (MassGrid::relax)
  std::size_t max_deletions_per_slice = 8;    // queued surface changes applied per slice
};

/// replay_lockstep (haptics/replay.h) with the voxel model's stages built from `model`
/// and, when sculpting, `sculpt`.
ReplaySummary replay_lockstep(const engine::ToolForceModel& model, Device& device,
                              const DeviceLimits& limits, SessionWriter* session,
                              const ProgressFn& progress = {}, SculptContext* sculpt = nullptr,
                              SculptSummary* sculpt_summary = nullptr,
                              const LockstepRender* render = nullptr);

/// replay_realtime (haptics/realtime.h) with the voxel model's stages.
ReplaySummary replay_realtime(const engine::ToolForceModel& model, Device& device,
                              const DeviceLimits& limits, SessionWriter* session,
                              const ProgressFn& progress, RealtimeSculpt* sculpt,
                              SculptSummary* sculpt_summary, TimingSummary* timing,
                              const RealtimeOptions& options = {});

}  // namespace hapvox::haptics
