#pragma once
// The density field shared by the force thread (one reader) and the relaxation thread
// (one writer), kept in two buffers (a "left-right" scheme).
//
// Why not one OpenVDB tree: a tree must not be read while another thread changes its
// topology, and relaxation creates and empties leaves all the time. Why not a snapshot
// per change: copying a tree costs milliseconds. Here the reader never waits: each tick
// it loads which buffer is the front one and announces that it reads it (one atomic load,
// one atomic store, no allocation). The writer only ever writes the back buffer: it
// applies the changed voxels and publishes the back buffer as the new front. The old
// front gets the same changes at the next publication, which first waits (if it must)
// until the reader has announced the switch away from it.

#include <atomic>
#include <cstdint>
#include <vector>

#include "engine/density_field.h"
#include "engine/relax.h"

namespace hapvox::haptics {

class DoubleBufferedField {
 public:
  /// Both buffers start as deep copies of `initial`.
  explicit DoubleBufferedField(const engine::DensityField& initial);

  engine::DensityField& buffer(int index) { return buffers_[index]; }
  const engine::DensityField& buffer(int index) const { return buffers_[index]; }

  /// Reader (force thread), once per tick: the buffer to read this tick. Wait-free.
  int acquire_for_reading() {
    const int front = front_.load(std::memory_order_acquire);
    reading_.store(front, std::memory_order_release);
    return front;
  }

  /// Reader: the newest plastic event the buffer it acquired has taken in (the `event`
  /// of the publication that made it the front; -1 before any). Read while in the buffer.
  std::int64_t published_event(int index) const {
    return events_[index].load(std::memory_order_acquire);
  }

  /// Writer (relaxation thread): waits (sleeping) until the reader has left the back
  /// buffer (or `reader_done` is set), brings it up to date with `mass` and makes it the
  /// front, stamped with `event`: the newest plastic event the mass grid has taken in.
  /// With nothing to write both buffers already match the grid: both take the stamp, and
  /// nothing is flipped.
  /// Returns the number of voxels written. With `changed`, appends the voxels the mass grid
  /// changed since the last publication (for the render thread's feed).
  std::size_t publish(engine::MassGrid& mass, const std::atomic<bool>& reader_done,
                      std::vector<openvdb::Coord>* changed = nullptr, std::int64_t event = -1);

  /// Writer, when no reader runs (before start or after join): both buffers up to date.
  void publish_unsynchronized(engine::MassGrid& mass,
                              std::vector<openvdb::Coord>* changed = nullptr,
                              std::int64_t event = -1);

  int front() const { return front_.load(std::memory_order_acquire); }
  /// Writer: the reader has left the back buffer, so a publication now would not wait.
  bool back_is_free() const {
    return reading_.load(std::memory_order_acquire) != 1 - front_.load(std::memory_order_relaxed);
  }

 private:
  std::size_t write_into(int index, engine::MassGrid& mass);

  engine::DensityField buffers_[2];
  std::atomic<int> front_{0};
  std::atomic<int> reading_{0};
  std::atomic<std::int64_t> events_[2] = {-1, -1};  // each buffer's publication stamp
  // Writer-only: voxels changed since each buffer was last written.
  std::vector<openvdb::Coord> fresh_;
  std::vector<openvdb::Coord> owed_to_back_;
};

}  // namespace hapvox::haptics
