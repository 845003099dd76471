#pragma once
// The fuzz targets' contract for the force path (issue 27): whatever positions a parsed
// trace or packet stream gives, every force sent is finite, within the device maximum, and
// continuous: from one tick to the next it changes by at most the ramp's step of the
// maximum plus what the model itself can change over a move a hand can make. The model
// here is a spring towards the origin (k = 0.1 N/mm), so a jump the guard let through, or a
// fault that zeroed the force, would break the bound.

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>

#include "haptics/replay.h"
#include "haptics/trace_device.h"

namespace hapvox::testing {

class SpringStage final : public haptics::ForceStage {
 public:
  static constexpr double kStiffnessNPerMm = 0.1;
  haptics::Vec3d step(const haptics::Vec3d& tool_mm, haptics::TickRecord&) noexcept override {
    return -kStiffnessNPerMm * tool_mm;
  }
  haptics::ForceStageCounters counters() const noexcept override { return {}; }
  void write_attributes(haptics::SessionWriter&) const override {}
};

/// Runs `positions_mm` (one a tick, device frame = volume frame, 1 kHz) through the force
/// stage and aborts unless every force sent keeps the contract. At most `max_ticks` ticks.
inline void abort_unless_forces_safe(const std::vector<haptics::Vec3d>& positions_mm,
                                     std::size_t max_ticks = 4000) {
  haptics::ResampledTrace trace;
  const std::size_t ticks = std::min(positions_mm.size(), max_ticks);
  for (std::size_t k = 0; k < ticks; ++k) {
    trace.time_s.push_back(static_cast<double>(k) / trace.rate_hz);
    trace.position_mm.push_back(positions_mm[k]);
    trace.holding.push_back(0);
  }
  haptics::TraceDevice device(std::move(trace), haptics::DeviceTransform{});
  const haptics::DeviceLimits limits;
  haptics::ForceSafety safety(limits, device.rate_hz());
  SpringStage stage;
  const double bound_n = limits.max_force_n * safety.ramp.step() +
                         SpringStage::kStiffnessNPerMm * safety.motion.max_step_mm() + 1e-9;
  haptics::Vec3d previous_n = haptics::Vec3d::Zero();
  for (std::size_t tick = 0; tick < ticks; ++tick) {
    haptics::TickRecord row;
    haptics::run_force_stage(stage, device, tick, limits, safety, row);
    const haptics::Vec3d& sent = row.force_n;
    if (!sent.allFinite() || sent.norm() > limits.max_force_n * (1 + 1e-12)) std::abort();
    if ((sent - previous_n).norm() > bound_n) std::abort();
    previous_n = sent;
  }
}

}  // namespace hapvox::testing
