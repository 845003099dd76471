#pragma once
// The seams between the loops and a deformation model (docs/architecture.md). A model
// (the voxel model of Prados: haptics/voxel_model.h; Nakao's proxy-mesh FEM:
// haptics/fem_model.h)
// is used by the lockstep and realtime loops, the session writer and the renderer only
// through these:
//
//   ForceStage        the 1 kHz stage: a tool pose in; the model's force, its contact and
//                     events out (into the tick's row); hand-offs to the background stage.
//                     No allocation, lock, I/O or exception; problems counted.
//   BackgroundStage   the slow stage on its own thread in realtime (relaxation, the FEM
//                     solve), a fixed budget per tick in lockstep; it publishes what the
//                     force stage reads through lock-free hand-offs of its own.
//   render side       what a frame is drawn with: the tick's tool pose and displacement
//                     (RenderToolState, the FFD's input, from the row), plus whatever the
//                     background stage streams to the render feed (changed voxels, the
//                     proxy mesh's node displacements).
//
// The loops own the threads and the clock; a stage owns its model's state and hand-offs.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "haptics/render_feed.h"
#include "haptics/session.h"

namespace hapvox::haptics {

/// Counters a force stage keeps (problems are counted on the force path, never logged).
struct ForceStageCounters {
  std::uint64_t contact_onsets = 0;
  std::uint64_t nonfinite_forces = 0;  // non-finite model forces the stage zeroed itself
};

/// The 1 kHz stage of a deformation model: one run's mutable state on the force thread.
class ForceStage {
 public:
  virtual ~ForceStage() = default;

  /// Realtime, at the start of every tick: takes up what the background stage published
  /// last (e.g. the front buffer of a double-buffered field). Wait-free.
  virtual void acquire_published() noexcept {}

  /// One tick with the tool centre at `tool_center_mm` (volume space): returns the model's
  /// force (N) before it is made safe, and fills the model's fields of `row`:
  /// displacement_mm, contact_area_mm2, contact, strain, stress_measure_pa, zone,
  /// plastic_event and, with a hand-off queue, queue_depth. Hands any event to the
  /// background stage. Does not allocate, lock, do I/O or throw.
  virtual Vec3d step(const Vec3d& tool_center_mm, TickRecord& row) noexcept = 0;

  /// After the last tick, on the force thread: tries to hand over anything still held
  /// back for the background stage. False while something is left (call again).
  virtual bool flush_handoffs() noexcept { return true; }

  virtual ForceStageCounters counters() const noexcept = 0;

  /// The model's configuration as session attributes ("model", material, tool, law).
  virtual void write_attributes(SessionWriter& session) const = 0;
};

/// What a background stage's realtime thread measured.
struct BackgroundTiming {
  std::vector<std::int64_t> slice_ns;        // every slice that did work, in order
  std::vector<std::int64_t> slice_start_ns;  // from the start of the run
  double cpu_s = 0.0;                        // the thread's CPU time
  std::size_t slice_max_deletions = 0;       // most surface changes one slice applied
  std::size_t slice_max_steps = 0;           // most relaxation steps one slice took
  std::size_t fifo_demotions = 0;  // paced lockstep: steps down from SCHED_FIFO (realtime.cc)
};

/// What a background stage did over a run (zeros where a model has no such work).
/// plastic_events and max_queue_depth come from the rows (the loop fills them).
struct SculptSummary {
  std::uint64_t plastic_events = 0;
  std::uint64_t queue_overflows = 0;
  std::uint64_t deleted_voxels = 0;
  std::uint64_t relaxed_voxels = 0;
  std::int64_t initial_mass_units = 0;
  std::int64_t final_mass_units = 0;
  std::size_t max_queue_depth = 0;
  bool settled = false;
  // What the loop left for finish(): hand-offs still queued (a coalesced one still with
  // the force stage is not counted), voxels waiting to relax (an upper bound:
  // MassGrid::queued), and how long applying the queued ones and finishing the flows took.
  std::size_t backlog_changes = 0;
  std::size_t backlog_voxels = 0;
  double drain_s = 0.0;
};

/// Lockstep rendering: `frame` is called every `every_ticks` ticks (and after the last)
/// with the tool pose of that tick; `voxel_changed` for every voxel the background stage
/// changed, as it is published to the force stage, so a renderer's copy stays in step;
/// `mesh_changed` after every FEM step of the proxy-mesh model, with the tick it solved for,
/// the mesh (the run's `mesh_index`-th: 0 its first) and its node displacements (mm, 3 per
/// vertex), valid for the call only.
struct LockstepRender {
  std::size_t every_ticks = 100;
  std::function<void(std::size_t tick, const RenderToolState& tool)> frame;
  std::function<void(const openvdb::Coord& ijk, float density)> voxel_changed;
  std::function<void(std::int64_t tick, const engine::fem::TetMesh& mesh, int mesh_index,
                     const std::vector<double>& displacement_mm)>
      mesh_changed;
};

/// The background stage of a deformation model.
class BackgroundStage {
 public:
  virtual ~BackgroundStage() = default;

  /// Before either loop starts: the state the run begins from (e.g. the exact mass).
  virtual void begin() = 0;

  /// Lockstep, after tick `tick`'s force stage: the stage's fixed work for one tick, its
  /// results published to the force stage before the next tick (and to `render`), and its
  /// fields of `row` filled (deleted_voxels, relaxed_voxels, total_mass_units).
  /// Bit-reproducible.
  virtual void run_lockstep_tick(std::size_t tick, TickRecord& row,
                                 const LockstepRender* render) = 0;

  /// Realtime, on the background thread: works in bounded slices until `force_done` is
  /// set, sleeping while there is no work; streams what the renderer needs into `feed`
  /// (when not null). Fills `timing`.
  virtual void run_realtime(const std::atomic<bool>& force_done,
                            std::chrono::steady_clock::time_point start, RenderFeed* feed,
                            BackgroundTiming& timing) = 0;
  /// Realtime, on the force thread: the stage's running totals into `row` (relaxed atomic
  /// loads; no allocation, lock or I/O).
  virtual void fill_realtime_row(TickRecord& row) noexcept = 0;
  /// Realtime, on the force thread after its last tick and `force_done`: wakes a sleeping
  /// background thread so that it finishes.
  virtual void wake() noexcept = 0;

  /// After the last lockstep tick, or once the realtime threads are joined: completes
  /// every queued change and publishes it (to the lockstep `render`, or to the realtime
  /// `feed` until `render_finished` is set), so the model holds the final state. Returns
  /// what the stage did.
  virtual SculptSummary finish(const LockstepRender* render, RenderFeed* feed,
                               const std::atomic<bool>* render_finished) = 0;
};

}  // namespace hapvox::haptics
