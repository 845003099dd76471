#include "haptics/mouse_device.h"

#include <cmath>

#include "engine/errors.h"
#include "haptics/session.h"

namespace hapvox::haptics {

MouseDevice::MouseDevice(const MouseDeviceOptions& options)
    : options_(options),
      max_step_mm_(options.max_speed_mm_s / options.rate_hz),
      position_mm_(options.start_mm) {
  if (!(options.rate_hz > 0.0) || !std::isfinite(options.rate_hz)) {
    throw InputError("mouse device", "the rate must be positive");
  }
  if (!(options.max_speed_mm_s > 0.0) || !std::isfinite(options.max_speed_mm_s)) {
    throw InputError("mouse device", "the tool's speed must be positive");
  }
  target_.write(
      Target{{options.start_mm.x(), options.start_mm.y(), options.start_mm.z()}, 0, false});
}

void MouseDevice::set_target(const Vec3d& target_mm, bool released) noexcept {
  if (!target_mm.allFinite()) return;  // a window's arithmetic gone wrong moves nothing
  const std::uint64_t sequence = targets_set_.load() + 1;
  target_.write(Target{{target_mm.x(), target_mm.y(), target_mm.z()}, sequence, released});
  targets_set_.store(sequence);
}

void MouseDevice::read(std::size_t tick, DeviceReading& reading) {
  const Target target = target_.read();
  // Towards the target by at most one step: the tool moves no faster than max_speed_mm_s.
  Vec3d step =
      Vec3d(target.position_mm[0], target.position_mm[1], target.position_mm[2]) - position_mm_;
  const double length = step.norm();
  if (length > max_step_mm_) step *= max_step_mm_ / length;
  position_mm_ += step;
  released_ = target.released;
  reading.time_s = static_cast<double>(tick) / options_.rate_hz;
  reading.position_mm = position_mm_;
  reading.sequence = static_cast<std::int64_t>(target.sequence);
  reading.holding = false;  // a pointer always has a position: a still one is not a fault
  reading.silent = false;
  reading.released = target.released;
  reading.buttons = 0;
}

void MouseDevice::send(std::size_t tick, const Vec3d& force_device_n, const TickRecord& row,
                       bool fault) {
  (void)force_device_n, (void)fault;  // the identity transform: the row's force is it
  feedback_.write(feedback_of(tick, row, released_));
}

}  // namespace hapvox::haptics
