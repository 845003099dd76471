// The force loop behind the public API (include/hapvox/loop.h): lockstep and realtime runs
// through the loops `hapvox replay` uses, and ForceStage, one tick of the same force stage
// per call from the application's own loop.

#include <atomic>

#include "api/internal.h"
#include "api/run_state.h"
#include "engine/errors.h"
#include "haptics/realtime.h"
#include "haptics/replay.h"
#include "hapvox/loop.h"
#include "hapvox/version.h"

namespace hapvox {

namespace {

haptics::DeviceLimits checked_limits(const LoopOptions& options) {
  cli::ReplayFlags f;  // --max-force-n, --ramp-in-s, --cpu as the command line checks them
  f.limits.max_force_n = options.max_force_n;
  f.limits.ramp_in_s = options.ramp_in_s;
  f.cpu = options.cpu;
  cli::check_loop_flags(f);
  return f.limits;
}

RunSummary summary_of(const haptics::ReplaySummary& s, const haptics::SculptSummary& sculpted,
                      const haptics::TimingSummary* timing) {
  RunSummary out;
  out.ticks = s.ticks;
  out.contact_ticks = s.contact_ticks;
  out.peak_force_n = s.peak_force_n;
  out.clamped_ticks = s.clamped_ticks;
  out.nonfinite_forces = s.nonfinite_forces;
  out.motion_faults = s.motion_faults;
  out.compute_p50_us = s.compute_p50_us;
  out.compute_p99_us = s.compute_p99_us;
  out.compute_max_us = s.compute_max_us;
  if (timing != nullptr) {
    out.lateness_p99_us = timing->lateness.p99_us;
    out.watchdog_trips = timing->watchdog_trips;
  }
  out.initial_mass_units = sculpted.initial_mass_units;
  out.final_mass_units = sculpted.final_mass_units;
  return out;
}

RunSummary run(const Model& model, Device& device, const LoopOptions& options, bool realtime) {
  const haptics::DeviceLimits limits = checked_limits(options);
  haptics::Device& dev = *device.impl().device;
  if (!realtime && dev.tick_count() == haptics::Device::kUnbounded) {
    throw InputError("device", "a lockstep run needs a device with a known tick count");
  }
  api::ModelRun state(model.impl(), realtime);
  double t0_s = 0.0;  // the time of tick 0 (FEM steps are timed from it)
  if (dev.tick_count() > 0) {
    // The FEM's first snapshot where the tool starts (as replay_fem.cc makes it).
    state.start(device.impl().first_tool_position_mm());
  }
  std::unique_ptr<haptics::SessionWriter> session;
  if (!options.session_path.empty()) {
    session = std::make_unique<haptics::SessionWriter>(options.session_path);
    session->set_attribute("command_line", std::string("hapvox API ") + HAPVOX_VERSION_STRING);
    session->set_attribute("rate_hz", dev.rate_hz());
    session->set_attribute("max_force_n", limits.max_force_n);
    session->set_attribute("ramp_in_s", limits.ramp_in_s);
  }
  haptics::ReplaySummary s;
  haptics::SculptSummary sculpted;
  haptics::TimingSummary timing;
  try {
    if (realtime) {
      haptics::RealtimeOptions realtime_options;
      realtime_options.scheduler.lock_memory = options.lock_memory;
      realtime_options.scheduler.lock_future_memory = options.lock_memory;
      realtime_options.scheduler.realtime_policy = options.realtime_priority;
      realtime_options.scheduler.pin_cpu = options.cpu >= 0;
      realtime_options.scheduler.cpu = options.cpu;
      s = haptics::replay_realtime(state.force(), state.background(), dev, limits, session.get(),
                                   {}, &sculpted, &timing, realtime_options);
    } else {
      s = haptics::replay_lockstep(state.force(), state.background(), dev, limits, session.get(),
                                   {}, &sculpted);
    }
    if (session) {
      if (s.ticks > 0) t0_s = device.impl().first_time_s();
      session->set_attribute("summary_ticks", static_cast<std::int64_t>(s.ticks));
      session->set_attribute("summary_peak_force_n", s.peak_force_n);
      state.write_session(*session, t0_s, dev.rate_hz());
    }
  } catch (...) {
    if (session) session->abandon();
    throw;
  }
  if (session) session->close();
  return summary_of(s, sculpted, realtime ? &timing : nullptr);
}

/// The device of a ForceStage: the application hands each tick's sample in before the tick.
class SteppedDevice final : public haptics::Device {
 public:
  SteppedDevice(double rate_hz, const haptics::DeviceTransform& transform)
      : rate_hz_(rate_hz), transform_(transform) {}
  double rate_hz() const override { return rate_hz_; }
  std::size_t tick_count() const override { return kUnbounded; }
  const haptics::DeviceTransform& transform() const override { return transform_; }
  void read(std::size_t tick, haptics::DeviceReading& reading) override {
    reading = next_;
    reading.sequence = static_cast<std::int64_t>(tick);
  }
  void send(std::size_t, const haptics::Vec3d& force_device_n, const haptics::TickRecord&,
            bool) override {
    force_device_n_ = force_device_n;
  }

  haptics::DeviceReading next_;
  haptics::Vec3d force_device_n_ = haptics::Vec3d::Zero();

 private:
  double rate_hz_;
  haptics::DeviceTransform transform_;
};

std::array<double, 3> arr(const haptics::Vec3d& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace

RunSummary run_lockstep(const Model& model, Device& device, const LoopOptions& options) {
  return run(model, device, options, false);
}

RunSummary run_realtime(const Model& model, Device& device, const LoopOptions& options) {
  return run(model, device, options, true);
}

struct ForceStage::Impl {
  Impl(const Model& model, const LoopOptions& options, double rate_hz,
       const DeviceTransform& transform)
      : limits(checked_limits(options)),
        device(rate_hz, api::device_transform(transform)),
        safety(limits, rate_hz),
        state(model.impl(), false) {}

  haptics::DeviceLimits limits;
  SteppedDevice device;
  haptics::ForceSafety safety;
  api::ModelRun state;
  std::size_t tick = 0;
};

ForceStage::ForceStage(const Model& model, const LoopOptions& options, double rate_hz,
                       const DeviceTransform& transform) {
  (void)api::loop_clock(rate_hz);
  impl_ = std::make_unique<Impl>(model, options, rate_hz, transform);
}

ForceStage::~ForceStage() = default;

std::size_t ForceStage::ticks() const noexcept { return impl_->tick; }

ForceTick ForceStage::step(const ToolSample& sample) noexcept {
  Impl& s = *impl_;
  haptics::DeviceReading& reading = s.device.next_;
  reading.time_s = sample.time_s;
  reading.position_mm = {sample.position_mm[0], sample.position_mm[1], sample.position_mm[2]};
  reading.holding = sample.holding;
  // The tick of replay_lockstep (haptics/replay.cc), in its order: the force stage, then the
  // background stage's fixed work for the tick. The FEM stage is made at the first tick,
  // where the tool is (its first snapshot; a grab holds what lies within reach of it).
  if (s.tick == 0) {
    s.state.start(s.device.transform().apply(reading.position_mm));
    if (s.state.background() != nullptr) s.state.background()->begin();
  }
  haptics::BackgroundStage* background = s.state.background();
  haptics::TickRecord row;
  const bool fault =
      haptics::run_force_stage(s.state.force(), s.device, s.tick, s.limits, s.safety, row);
  if (background != nullptr) background->run_lockstep_tick(s.tick, row, nullptr);
  ++s.tick;
  ForceTick out;
  out.force_n = arr(row.force_n);
  out.force_device_n = arr(s.device.force_device_n_);
  out.tool_position_mm = arr(row.tool_position_mm);
  out.displacement_mm = arr(row.displacement_mm);
  out.force_scale = row.force_scale;
  out.contact_area_mm2 = row.contact_area_mm2;
  out.contact = row.contact != 0;
  out.clamped = row.clamped != 0;
  out.fault = fault;
  return out;
}

}  // namespace hapvox
