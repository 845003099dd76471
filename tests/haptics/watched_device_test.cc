// ObservedDevice: any device, watched by a window. Every call reaches the device it wraps;
// what was sent comes back as feedback in the volume's frame; the window can end the
// session, and so can the device.

#include "haptics/watched_device.h"

#include <gtest/gtest.h>

#include "haptics/session.h"

namespace hapvox::haptics {
namespace {

// A device that remembers what the loop did with it.
class RecordingDevice final : public Device {
 public:
  double rate_hz() const override { return 500.0; }
  std::size_t tick_count() const override { return 7; }
  const DeviceTransform& transform() const override { return transform_; }
  void read(std::size_t tick, DeviceReading& reading) override {
    reading.position_mm = Vec3d(static_cast<double>(tick), 0.0, 0.0);
    reading.released = tick == 3;
  }
  void send(std::size_t tick, const Vec3d& force_device_n, const TickRecord&, bool fault) override {
    last_tick = tick;
    last_force_n = force_device_n;
    last_fault = fault;
  }
  bool finished() const override { return ended; }
  int gap_count() const override { return 2; }
  double held_time_s() const override { return 0.25; }

  DeviceTransform transform_;
  std::size_t last_tick = 0;
  Vec3d last_force_n = Vec3d::Zero();
  bool last_fault = false;
  bool ended = false;
};

TEST(ObservedDevice, PassesEveryCallOnAndGivesBackWhatWasSent) {
  RecordingDevice inner;
  ObservedDevice device(inner);
  EXPECT_EQ(device.rate_hz(), 500.0);
  EXPECT_EQ(device.tick_count(), 7u);
  EXPECT_EQ(&device.transform(), &inner.transform_);
  EXPECT_EQ(device.gap_count(), 2);
  EXPECT_EQ(device.held_time_s(), 0.25);
  EXPECT_EQ(device.feedback().tick, -1);

  DeviceReading reading;
  device.read(3, reading);
  EXPECT_EQ(reading.position_mm.x(), 3.0);
  TickRecord row;
  row.tool_position_mm = Vec3d(1.0, 2.0, 3.0);
  row.force_n = Vec3d(0.5, 0.0, -1.5);  // the volume's frame: what the window draws
  row.force_scale = 0.25;
  row.contact = 1;
  const Vec3d device_force_n(0.0, 1.5, 0.5);  // the device's frame: what the device gets
  device.send(3, device_force_n, row, true);
  EXPECT_EQ(inner.last_tick, 3u);
  EXPECT_EQ(inner.last_force_n, device_force_n);
  EXPECT_TRUE(inner.last_fault);
  const DeviceFeedback feedback = device.feedback();
  EXPECT_EQ(feedback.tick, 3);
  EXPECT_EQ(feedback.force_n[0], 0.5);
  EXPECT_EQ(feedback.force_n[2], -1.5);
  EXPECT_EQ(feedback.position_mm[1], 2.0);
  EXPECT_EQ(feedback.force_scale, 0.25);
  EXPECT_TRUE(feedback.contact);
  EXPECT_TRUE(feedback.released);  // the reading of that tick released the dead-man

  // Either side ends the session.
  EXPECT_FALSE(device.finished());
  inner.ended = true;
  EXPECT_TRUE(device.finished());
  inner.ended = false;
  device.request_end();
  EXPECT_TRUE(device.finished());
}

}  // namespace
}  // namespace hapvox::haptics
