#pragma once
// What the render thread is fed in a realtime session, without ever blocking the force
// thread or sharing a tree with the relaxation:
//
//   force thread  -> ToolStateMailbox  the latest tool pose each tick (a seqlock: the writer
//                                       is wait-free, the reader retries a torn read)
//   relax thread  -> VoxelPatchQueue   every voxel it changed, with its new density, over a
//                                       bounded SPSC ring where neither side waits
//                                       (haptics/spsc_ring.h); what
//                                       does not fit waits in the relaxation thread's
//                                       backlog and goes with its next slice, never lost
//   FEM thread    -> TripleBuffer       the proxy mesh's latest node displacements (the
//                                       render thread resamples the volume from them)
//
// The render thread keeps its own copy of the field (render::VolumeRenderer), so it reads
// no OpenVDB tree another thread writes.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "engine/relax.h"
#include "haptics/spsc_ring.h"
#include "haptics/triple_buffer.h"

namespace hapvox::engine::fem {
struct TetMesh;
}

namespace hapvox::haptics {

using Vec3d = engine::Vec3d;

struct RenderToolState {
  Vec3d center_mm = Vec3d::Zero();
  Vec3d displacement_mm = Vec3d::Zero();  // u = x_n - x0
  bool in_contact = false;
  std::int64_t tick = -1;  // -1: nothing published yet
};

class ToolStateMailbox {
 public:
  /// Writer (force thread): wait-free, no allocation.
  void publish(const RenderToolState& state) noexcept;
  /// Reader (render thread): the latest complete state.
  RenderToolState read() const noexcept;

 private:
  std::atomic<std::uint64_t> sequence_{0};  // odd while the writer is mid-update
  std::atomic<double> values_[6] = {};
  std::atomic<bool> in_contact_{false};
  std::atomic<std::int64_t> tick_{-1};
};

struct VoxelPatch {
  openvdb::Coord ijk;
  float density = 0.0f;
};

class VoxelPatchQueue {
 public:
  static constexpr unsigned kCapacity = 1u << 16;

  /// Producer (relaxation thread): offers `coords` with their current densities from
  /// `mass`, and first whatever an earlier call could not fit. Never blocks.
  void offer(const std::vector<openvdb::Coord>& coords, engine::MassGrid& mass);
  /// Producer: true when nothing waits in the backlog.
  bool drained_backlog() const { return backlog_.empty(); }
  /// Consumer (render thread). False when empty.
  bool pop(VoxelPatch& patch) { return queue_.try_pop(patch); }
  /// Producer (a background stage paced in lockstep, haptics/realtime.h): one changed voxel
  /// with its density; what does not fit waits, in order, for retry_patches. Never blocks.
  void offer_patch(const VoxelPatch& patch);
  /// Producer: pushes what offer_patch kept back; true when nothing waits any more.
  bool retry_patches();
  /// Times the queue was full (the producer kept the rest for later).
  std::uint64_t full_events() const { return full_events_.load(std::memory_order_relaxed); }

 private:
  SpscRing<VoxelPatch, kCapacity> queue_;
  std::vector<VoxelPatch> patch_backlog_;  // producer-only: offer_patch's, in order
  std::size_t patch_backlog_head_ = 0;
  std::vector<openvdb::Coord> backlog_;  // producer-only
  std::vector<openvdb::Coord> pending_;  // producer-only scratch
  std::atomic<std::uint64_t> full_events_{0};
};

/// Frame timing of the render thread, filled by whoever renders.
struct RenderTiming {
  std::vector<std::int64_t> frame_start_ns;  // from the start of the run
  std::vector<std::int64_t> frame_ns;        // render() to pixels read back
  std::vector<std::int64_t> frame_tick;      // the tick whose pose the frame shows
  std::uint64_t voxels_applied = 0;
  std::uint64_t frames_written = 0;

  /// Records a frame that began at `begin` and ends now, showing tick `tick`.
  void record_frame(std::chrono::steady_clock::time_point run_start,
                    std::chrono::steady_clock::time_point begin, std::int64_t tick) {
    using std::chrono::duration_cast;
    using std::chrono::nanoseconds;
    frame_start_ns.push_back(duration_cast<nanoseconds>(begin - run_start).count());
    frame_ns.push_back(
        duration_cast<nanoseconds>(std::chrono::steady_clock::now() - begin).count());
    frame_tick.push_back(tick);
    ++frames_written;
  }
};

/// The proxy-FEM model's node displacements after one FEM step.
struct MeshDisplacement {
  std::int64_t tick = -1;                      // -1: nothing published yet
  const engine::fem::TetMesh* mesh = nullptr;  // lives as long as the run's stages
  int mesh_index = 0;                          // 0: the run's first mesh; k: its k-th remesh
  std::vector<double> displacement_mm;         // 3 per vertex of *mesh
};

/// The force loop as the session writer last saw it (~10 times a second), for a window's
/// overlay: written by the calling thread of replay_realtime, read by the render thread.
struct LoopStats {
  std::atomic<std::uint64_t> ticks{0};            // ticks run so far
  std::atomic<std::uint64_t> missed{0};           // ticks that ended after the next deadline
  std::atomic<std::uint64_t> watchdog_trips{0};   // ticks that overran the watchdog
  std::atomic<double> rate_hz{0.0};               // ticks per second over the last update
  std::atomic<double> p99_lateness_us{0.0};       // over the whole run so far
  std::atomic<std::int64_t> total_mass_units{0};  // the sculpted clay's, the last row's
};

struct RenderFeed {
  std::chrono::steady_clock::time_point start;  // tick 0's deadline; set before threads start
  LoopStats loop;
  ToolStateMailbox tool;
  VoxelPatchQueue voxels;
  TripleBuffer<MeshDisplacement> mesh;
  /// Set once the force and relaxation threads are finished and every change is queued:
  /// the render loop drains the queue, draws a last frame and returns.
  std::atomic<bool> done{false};
};

/// A render loop for replay_realtime to run on its own thread: it must return soon after
/// feed.done is set. Owns its GL context (made current on the calling thread).
using RenderLoop = std::function<void(RenderFeed& feed, RenderTiming& timing)>;

}  // namespace hapvox::haptics
