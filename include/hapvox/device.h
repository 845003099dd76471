#pragma once
// What moves the tool: a replayed trace, or your own callback (a haptic device's driver, a
// script, a controller). The loop reads the device once per tick and sends it the force.

#include <array>
#include <cstddef>
#include <functional>
#include <memory>

#include "hapvox/trace.h"

namespace hapvox {

/// Device frame -> volume frame: p_volume = offset + R * (scale * p_device), R the rotation
/// by rotate_deg about x, then y, then z (`--scale`, `--rotate-deg`, `--offset-mm`).
/// Forces go back to the device through R's transpose.
struct DeviceTransform {
  double scale = 1.0;
  std::array<double, 3> rotate_deg = {0.0, 0.0, 0.0};
  std::array<double, 3> offset_mm = {0.0, 0.0, 0.0};
};

/// Called once per tick, in tick order, for the tool's position. In a realtime loop it runs
/// on the force thread: it must return quickly and should not allocate or lock.
using DeviceReadFn = std::function<ToolSample(std::size_t tick)>;
/// Called once per tick after the force is computed: the force to render, in newtons, in
/// the device frame (finite, clamped to max_force_n, ramped).
using DeviceForceFn = std::function<void(std::size_t tick, const std::array<double, 3>& force_n)>;

class Device {
 public:
  /// Replays `trace` resampled at rate_hz (a gap longer than max_gap_s holds the tool).
  static Device trace(const Trace& trace, const DeviceTransform& transform = {},
                      double rate_hz = 1000.0, double max_gap_s = 0.05);
  /// Your own device: `ticks` ticks at rate_hz, positions from `read`, forces to
  /// `on_force` (if given). Throws InputError("device", ...) on a rate that is not positive
  /// or an empty `read`.
  static Device callback(DeviceReadFn read, std::size_t ticks, double rate_hz = 1000.0,
                         const DeviceTransform& transform = {}, DeviceForceFn on_force = {});

  ~Device();
  Device(Device&&) noexcept;
  Device& operator=(Device&&) noexcept;

  double rate_hz() const;
  std::size_t ticks() const;

  struct Impl;
  Impl& impl() { return *impl_; }

 private:
  explicit Device(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;  // a device has state (its position in the trace): not copied
};

}  // namespace hapvox
