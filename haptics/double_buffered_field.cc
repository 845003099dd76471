#include "haptics/double_buffered_field.h"

#include <chrono>
#include <thread>

namespace hapvox::haptics {
namespace {

engine::DensityField deep_copy(const engine::DensityField& field) {
  return engine::DensityField(field.grid().deepCopy(), field.voxel_size_mm(), field.origin_mm(),
                              field.dims(), field.direction());
}

}  // namespace

DoubleBufferedField::DoubleBufferedField(const engine::DensityField& initial)
    : buffers_{deep_copy(initial), deep_copy(initial)} {}

std::size_t DoubleBufferedField::write_into(int index, engine::MassGrid& mass) {
  auto out = buffers_[index].mutable_grid().getAccessor();
  std::size_t written = 0;
  for (const auto* list : {&owed_to_back_, &fresh_}) {
    for (const openvdb::Coord& ijk : *list) {
      const float rho = mass.density(ijk);
      if (rho == 0.0f) {
        out.setValueOff(ijk, 0.0f);
      } else {
        out.setValueOn(ijk, rho);
      }
      ++written;
    }
  }
  return written;
}

std::size_t DoubleBufferedField::publish(engine::MassGrid& mass,
                                         const std::atomic<bool>& reader_done,
                                         std::vector<openvdb::Coord>* changed, std::int64_t event) {
  mass.take_changes(fresh_);
  if (changed != nullptr) changed->insert(changed->end(), fresh_.begin(), fresh_.end());
  if (fresh_.empty() && owed_to_back_.empty()) {
    // Both buffers hold the grid as it is: whichever the reader is in has taken the event in.
    for (auto& stamp : events_) stamp.store(event, std::memory_order_release);
    return 0;
  }
  const int back = 1 - front_.load(std::memory_order_relaxed);
  // The back buffer was the front until the last publication: the reader may still be in
  // it until it announces the newer front. It reads every tick, so by now (a slice of work
  // later) it nearly always has, and the writer does not wait; waiting after the flip
  // instead slept in 50 us steps through most of a tick on every publication, waking on
  // the CPU the render thread needs.
  while (reading_.load(std::memory_order_acquire) == back &&
         !reader_done.load(std::memory_order_acquire)) {
    std::this_thread::sleep_for(std::chrono::microseconds(50));
  }
  const std::size_t written = write_into(back, mass);
  events_[back].store(event, std::memory_order_relaxed);  // made visible by the flip
  front_.store(back, std::memory_order_release);
  owed_to_back_.swap(fresh_);  // the new back buffer still lacks these
  fresh_.clear();
  return written;
}

void DoubleBufferedField::publish_unsynchronized(engine::MassGrid& mass,
                                                 std::vector<openvdb::Coord>* changed,
                                                 std::int64_t event) {
  mass.take_changes(fresh_);
  if (changed != nullptr) changed->insert(changed->end(), fresh_.begin(), fresh_.end());
  const int back = 1 - front_.load(std::memory_order_relaxed);
  write_into(back, mass);
  owed_to_back_.insert(owed_to_back_.end(), fresh_.begin(), fresh_.end());
  write_into(1 - back, mass);
  owed_to_back_.clear();
  fresh_.clear();
  for (auto& stamp : events_) stamp.store(event, std::memory_order_release);
}

}  // namespace hapvox::haptics
