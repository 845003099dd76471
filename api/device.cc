// hapvox::Device: a replayed trace, or the application's own callback
// (include/hapvox/device.h), behind the loops' device seam (haptics/device.h).

#include <cmath>
#include <optional>

#include "api/internal.h"
#include "engine/errors.h"
#include "haptics/trace_device.h"

namespace hapvox {

namespace {

/// The application's device: positions from its read callback, forces to its own.
class CallbackDevice final : public haptics::Device {
 public:
  CallbackDevice(DeviceReadFn read, DeviceForceFn on_force, std::size_t ticks, double rate_hz,
                 const haptics::DeviceTransform& transform)
      : read_(std::move(read)),
        on_force_(std::move(on_force)),
        ticks_(ticks),
        rate_hz_(rate_hz),
        transform_(transform) {}

  double rate_hz() const override { return rate_hz_; }
  std::size_t tick_count() const override { return ticks_; }
  const haptics::DeviceTransform& transform() const override { return transform_; }
  void read(std::size_t tick, haptics::DeviceReading& reading) override {
    // Tick 0 may have been asked for already (first_tool_position_mm): not twice.
    const ToolSample sample = tick == 0 && first_ ? *first_ : read_(tick);
    first_.reset();
    if (tick == 0) first_time_s_ = sample.time_s;
    reading.time_s = sample.time_s;
    reading.position_mm = {sample.position_mm[0], sample.position_mm[1], sample.position_mm[2]};
    reading.holding = sample.holding;
    reading.sequence = static_cast<std::int64_t>(tick);
  }
  void send(std::size_t tick, const haptics::Vec3d& force_device_n, const haptics::TickRecord&,
            bool) override {
    if (on_force_) on_force_(tick, {force_device_n.x(), force_device_n.y(), force_device_n.z()});
  }

  /// The tool at tick 0, volume frame: asked for once, kept for the loop's read of tick 0.
  haptics::Vec3d first_tool_position_mm() {
    if (!first_) first_ = read_(0);
    return transform_.apply(
        {first_->position_mm[0], first_->position_mm[1], first_->position_mm[2]});
  }

  double first_time_s() const { return first_time_s_; }

 private:
  std::optional<ToolSample> first_;
  double first_time_s_ = 0.0;
  DeviceReadFn read_;
  DeviceForceFn on_force_;
  std::size_t ticks_;
  double rate_hz_;
  haptics::DeviceTransform transform_;
};

}  // namespace

Device::Device(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Device::~Device() = default;
Device::Device(Device&&) noexcept = default;
Device& Device::operator=(Device&&) noexcept = default;

Device Device::trace(const Trace& trace, const DeviceTransform& transform, double rate_hz,
                     double max_gap_s) {
  const haptics::ResampleOptions clock = api::loop_clock(rate_hz, max_gap_s);
  auto impl = std::make_unique<Impl>();
  auto device = std::make_unique<haptics::TraceDevice>(haptics::resample(trace.impl().trace, clock),
                                                       api::device_transform(transform));
  haptics::TraceDevice* traced = device.get();
  impl->first_tool_position_mm = [traced] { return traced->tool_position_mm(0); };
  impl->first_time_s = [traced] { return traced->time_s(0); };
  impl->device = std::move(device);
  return Device(std::move(impl));
}

Device Device::callback(DeviceReadFn read, std::size_t ticks, double rate_hz,
                        const DeviceTransform& transform, DeviceForceFn on_force) {
  (void)api::loop_clock(rate_hz);
  if (!read) throw InputError("device", "no read callback");
  auto impl = std::make_unique<Impl>();
  auto device = std::make_unique<CallbackDevice>(std::move(read), std::move(on_force), ticks,
                                                 rate_hz, api::device_transform(transform));
  CallbackDevice* called = device.get();
  impl->first_tool_position_mm = [called] { return called->first_tool_position_mm(); };
  impl->first_time_s = [called] { return called->first_time_s(); };
  impl->device = std::move(device);
  return Device(std::move(impl));
}

double Device::rate_hz() const { return impl_->device->rate_hz(); }
std::size_t Device::ticks() const { return impl_->device->tick_count(); }

}  // namespace hapvox
