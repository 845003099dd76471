#pragma once
// A device a window watches (tools/sculpt_window.h): what the force thread sent for the last
// tick comes back to the window's thread (DeviceFeedback: the force arrow, the overlay's
// numbers), and the window can end the session. The mouse is one (haptics/mouse_device.h);
// ObservedDevice makes any other one so, e.g. the bridge when a device program moves the
// tool in a window (`hapvox sculpt --device udp:HOST:PORT`).
//
// Threads: send() on the force thread (a seqlock write: no lock, no allocation); feedback()
// and request_end() from any thread.

#include <atomic>
#include <cstdint>

#include "haptics/device.h"
#include "haptics/seqlock.h"

namespace hapvox::haptics {

/// What the force thread did with the last tick, for the window.
struct DeviceFeedback {
  std::int64_t tick = -1;             // -1: no tick yet
  double position_mm[3] = {0, 0, 0};  // the tool's centre (volume mm)
  double force_n[3] = {0, 0, 0};      // sent (volume frame): finite, clamped, ramped
  double force_scale = 0.0;           // the ramp factor it was sent with
  bool contact = false;
  bool released = false;  // the dead-man was released on that tick
};

/// The feedback for tick `tick` from its record.
DeviceFeedback feedback_of(std::size_t tick, const TickRecord& row, bool released) noexcept;

class WatchedDevice : public Device {
 public:
  /// The last tick's feedback (any thread).
  virtual DeviceFeedback feedback() const noexcept = 0;
  /// Ends the session: the loop stops before its next tick (any thread).
  virtual void request_end() noexcept = 0;
};

/// Any device, watched: every call goes to `inner`; send() also publishes the feedback, and
/// request_end() makes finished() true.
class ObservedDevice final : public WatchedDevice {
 public:
  explicit ObservedDevice(Device& inner) : inner_(inner) {}

  double rate_hz() const override { return inner_.rate_hz(); }
  std::size_t tick_count() const override { return inner_.tick_count(); }
  const DeviceTransform& transform() const override { return inner_.transform(); }
  bool reports_orientation() const override { return inner_.reports_orientation(); }
  Clock::time_point wait_for_tick(std::size_t tick, Clock::time_point deadline) override {
    return inner_.wait_for_tick(tick, deadline);
  }
  void read(std::size_t tick, DeviceReading& reading) override;
  void send(std::size_t tick, const Vec3d& force_device_n, const TickRecord& row,
            bool fault) override;
  bool finished() const override { return end_.load() || inner_.finished(); }
  int gap_count() const override { return inner_.gap_count(); }
  double held_time_s() const override { return inner_.held_time_s(); }

  DeviceFeedback feedback() const noexcept override { return feedback_.read(); }
  void request_end() noexcept override { end_.store(true); }

 private:
  Device& inner_;
  bool released_ = false;  // force thread only: the last reading's
  Seqlock<DeviceFeedback> feedback_;
  std::atomic<bool> end_{false};
};

}  // namespace hapvox::haptics
