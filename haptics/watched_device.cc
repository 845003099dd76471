#include "haptics/watched_device.h"

#include "haptics/session.h"

namespace hapvox::haptics {

DeviceFeedback feedback_of(std::size_t tick, const TickRecord& row, bool released) noexcept {
  DeviceFeedback feedback;
  feedback.tick = static_cast<std::int64_t>(tick);
  for (int a = 0; a < 3; ++a) {
    feedback.position_mm[a] = row.tool_position_mm[a];
    feedback.force_n[a] = row.force_n[a];
  }
  feedback.force_scale = row.force_scale;
  feedback.contact = row.contact != 0;
  feedback.released = released;
  return feedback;
}

void ObservedDevice::read(std::size_t tick, DeviceReading& reading) {
  inner_.read(tick, reading);
  released_ = reading.released;
}

void ObservedDevice::send(std::size_t tick, const Vec3d& force_device_n, const TickRecord& row,
                          bool fault) {
  inner_.send(tick, force_device_n, row, fault);
  feedback_.write(feedback_of(tick, row, released_));
}

}  // namespace hapvox::haptics
