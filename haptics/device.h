#pragma once
// The haptic device seen by the force loop: one small interface behind which a replayed
// trace (haptics/trace_device.h), the network bridge (haptics/bridge_device.h) or a mouse
// moves the tool. The loops (lockstep, realtime) read the device once per tick, compute the
// force, and send it back; the ramp, the clamp and the watchdog are theirs, the same for
// every device (haptics/replay.h).
//
// Called on the force thread: read() and send() take no locks, do not allocate and do not
// throw. A live device may do non-blocking socket I/O there (its device's own transport).

#include <Eigen/Core>
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "haptics/trace.h"

namespace hapvox::haptics {

struct TickRecord;

/// What a device reports for one tick of the force loop, in the device's own frame.
struct DeviceReading {
  double time_s = 0.0;                // the tick's time (a trace's clock; a live device's
                                      // seconds since the loop started)
  Vec3d position_mm = Vec3d::Zero();  // device frame; the device transform maps it
  std::uint32_t buttons = 0;          // kButtonGrab, ... (haptics/bridge_packet.h)
  std::int64_t sequence = -1;         // the sample it came from: a trace's tick, a packet's
                                      // sequence number
  bool holding = false;   // the position is held: a gap in a trace, a packet that did not come
  bool silent = false;    // a live device has been silent past its timeout: ramp the force out
  bool released = false;  // the dead-man is released: ramp the force out until pressed again
  // The stylus orientation (a unit quaternion w,x,y,z, device frame), where the device has
  // one (reports_orientation()); the identity otherwise. The sphere tool does not turn: it is
  // recorded for 6-DoF tools to come.
  std::array<double, 4> orientation_wxyz = {1.0, 0.0, 0.0, 0.0};
};

class Device {
 public:
  using Clock = std::chrono::steady_clock;
  /// tick_count() of a device with no known end (a live one): the loop runs until finished().
  static constexpr std::size_t kUnbounded = std::numeric_limits<std::size_t>::max();

  virtual ~Device() = default;

  /// The force loop's rate.
  virtual double rate_hz() const = 0;
  /// Ticks it will give, or kUnbounded.
  virtual std::size_t tick_count() const = 0;
  /// Whether read() gives the stylus orientation: the session then records it per tick
  /// (/device_orientation).
  virtual bool reports_orientation() const { return false; }
  /// Device frame -> volume (forces go back through its rotation).
  virtual const DeviceTransform& transform() const = 0;

  /// Realtime only: returns when tick `tick`, due at `deadline`, may start. A replayed trace
  /// sleeps, then spins, until the deadline; a live device that paces the loop returns as
  /// soon as its next reading arrives (or at its timeout). Returns the tick's scheduled time.
  virtual Clock::time_point wait_for_tick(std::size_t tick, Clock::time_point deadline);
  /// The state for tick `tick` (called once per tick, in order).
  virtual void read(std::size_t tick, DeviceReading& reading) = 0;
  /// The force sent for that tick, in the device frame, with the tick's record (clamped,
  /// ramp factor, fault). A replayed trace ignores it.
  virtual void send(std::size_t tick, const Vec3d& force_device_n, const TickRecord& row,
                    bool fault) {
    (void)tick, (void)force_device_n, (void)row, (void)fault;
  }
  /// A live device that has ended the session (its sender said so): the loop stops.
  virtual bool finished() const { return false; }

  /// Gaps in a replayed trace (for the summary); none for a live device.
  virtual int gap_count() const { return 0; }
  virtual double held_time_s() const { return 0.0; }
};

/// Sleeps until shortly before `deadline`, then spins to it (sleeping overshoots by up to
/// the timer slack).
void sleep_then_spin_until(Device::Clock::time_point deadline);

}  // namespace hapvox::haptics
