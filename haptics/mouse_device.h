#pragma once
// A mouse (or any pointer a window turns into a 3D target) as the force loop's device: the
// window's thread sets a target position (picking and dragging turn a cursor into one,
// tools/sculpt_window.h); the force thread moves the tool towards it by at most
// max_speed_mm_s per tick, so a cursor that jumps across the view never steps the tool (or
// the force). The loop's clock paces it, as a replayed trace; it runs until the window ends
// the session. What the force thread sent comes back to the window as DeviceFeedback (the
// force arrow, the overlay's numbers; haptics/watched_device.h).
//
// Threads: set_target and request_end from one window thread; read, send and finished from
// the force thread (no locks, no allocation: seqlocks); feedback from any thread.

#include <atomic>
#include <cstdint>

#include "haptics/seqlock.h"
#include "haptics/watched_device.h"

namespace hapvox::haptics {

struct MouseDeviceOptions {
  double rate_hz = 1000.0;
  double max_speed_mm_s = 200.0;   // how fast the tool follows the target
  Vec3d start_mm = Vec3d::Zero();  // the tool's position before any target (volume mm)
};

class MouseDevice final : public WatchedDevice {
 public:
  explicit MouseDevice(const MouseDeviceOptions& options);

  // The window's thread.
  /// The tool's target (volume mm); `released`: the dead-man is released (force ramps out).
  void set_target(const Vec3d& target_mm, bool released) noexcept;
  /// Ends the session: the loop stops before its next tick.
  void request_end() noexcept override { end_.store(true); }
  DeviceFeedback feedback() const noexcept override { return feedback_.read(); }
  /// Where the tool starts (volume mm).
  const Vec3d& start_mm() const noexcept { return options_.start_mm; }

  // The force thread.
  double rate_hz() const override { return options_.rate_hz; }
  std::size_t tick_count() const override { return kUnbounded; }
  const DeviceTransform& transform() const override { return transform_; }
  void read(std::size_t tick, DeviceReading& reading) override;
  void send(std::size_t tick, const Vec3d& force_device_n, const TickRecord& row,
            bool fault) override;
  bool finished() const override { return end_.load(); }

  /// Targets set so far (each is a reading's sequence number).
  std::uint64_t targets_set() const noexcept { return targets_set_.load(); }

 private:
  struct Target {
    double position_mm[3];
    std::uint64_t sequence;
    bool released;
  };

  MouseDeviceOptions options_;
  DeviceTransform transform_;  // identity: the window sets targets in volume mm
  double max_step_mm_;
  Vec3d position_mm_;      // force thread only
  bool released_ = false;  // force thread only: the last reading's
  Seqlock<Target> target_;
  Seqlock<DeviceFeedback> feedback_;
  std::atomic<std::uint64_t> targets_set_{0};
  std::atomic<bool> end_{false};
};

}  // namespace hapvox::haptics
