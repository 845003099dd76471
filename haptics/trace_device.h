#pragma once
// The device that replays a recorded trace: tick k is the resampled trace's sample k, mapped
// through the device transform. It paces nothing and answers nothing: the loop's clock
// decides when a tick runs, and the forces sent go only to the session.

#include <utility>

#include "haptics/device.h"
#include "haptics/trace.h"

namespace hapvox::haptics {

class TraceDevice final : public Device {
 public:
  TraceDevice(ResampledTrace trace, const DeviceTransform& transform)
      : trace_(std::move(trace)), transform_(transform) {}

  double rate_hz() const override { return trace_.rate_hz; }
  std::size_t tick_count() const override { return trace_.time_s.size(); }
  const DeviceTransform& transform() const override { return transform_; }
  bool reports_orientation() const override { return !trace_.orientation.empty(); }
  void read(std::size_t tick, DeviceReading& reading) override {
    reading.time_s = trace_.time_s[tick];
    reading.position_mm = trace_.position_mm[tick];
    if (!trace_.orientation.empty()) {
      const Eigen::Quaterniond& q = trace_.orientation[tick];
      reading.orientation_wxyz = {q.w(), q.x(), q.y(), q.z()};
    }
    reading.holding = trace_.holding[tick] != 0;
    reading.sequence = static_cast<std::int64_t>(tick);
  }
  int gap_count() const override { return trace_.gap_count; }
  double held_time_s() const override { return trace_.held_time_s; }

  double time_s(std::size_t tick) const { return trace_.time_s[tick]; }
  const Vec3d& device_position_mm(std::size_t tick) const { return trace_.position_mm[tick]; }
  Vec3d tool_position_mm(std::size_t tick) const {
    return transform_.apply(trace_.position_mm[tick]);
  }
  bool holding(std::size_t tick) const { return trace_.holding[tick] != 0; }
  const ResampledTrace& trace() const { return trace_; }

 private:
  ResampledTrace trace_;
  DeviceTransform transform_;
};

}  // namespace hapvox::haptics
