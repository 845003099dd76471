#include "haptics/force_safety.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hapvox::haptics {

Vec3d safe_force(const Vec3d& raw_n, double ramp, const DeviceLimits& limits, bool* clamped,
                 bool* nonfinite) {
  *clamped = false;
  *nonfinite = !raw_n.allFinite();
  if (*nonfinite) return Vec3d::Zero();
  Vec3d force = raw_n;
  double magnitude = force.norm();
  if (!std::isfinite(magnitude)) {
    // |F|^2 overflowed (components of 1e170 N): |F| is far beyond any device's maximum, and
    // the direction comes from the force scaled down by its largest component.
    const Vec3d scaled = force / force.cwiseAbs().maxCoeff();
    *clamped = true;
    return std::clamp(ramp, 0.0, 1.0) * limits.max_force_n * scaled.normalized();
  }
  if (magnitude > limits.max_force_n) {
    force *= limits.max_force_n / magnitude;
    *clamped = true;
  }
  return std::clamp(ramp, 0.0, 1.0) * force;
}

ForceRamp::ForceRamp(const DeviceLimits& limits, double rate_hz) {
  const double steps = limits.ramp_in_s * rate_hz;
  if (std::isfinite(steps) && steps > 0.0) {
    steps_ = steps;
    top_ = static_cast<std::int64_t>(std::ceil(steps));
  }
}

double ForceRamp::factor() const {
  if (level_ < 0) return 0.0;
  if (steps_ == 0.0) return 1.0;
  return std::min(1.0, static_cast<double>(level_) / steps_);
}

void ForceRamp::trip() {
  ++trips_;
  if (steps_ == 0.0) return;  // no ramp: nothing to fall by
  falling_ = true;
  recovering_ = true;
}

double ForceRamp::next(bool hold_down) {
  if (steps_ == 0.0) {
    level_ = 0;
    return hold_down ? 0.0 : 1.0;
  }
  if (hold_down) {
    level_ = std::max<std::int64_t>(0, level_ - 1);
  } else if (falling_) {
    level_ = std::max<std::int64_t>(0, level_ - 1);
    if (level_ == 0) falling_ = false;  // at zero: rise from the next tick
  } else {
    level_ = std::min(level_ + 1, top_);
  }
  const double f = factor();
  if (recovering_) {
    if (f < 1.0) {
      ++reduced_ticks_;
    } else {
      recovering_ = false;
    }
  }
  return f;
}

MotionGuard::MotionGuard(const DeviceLimits& limits, double rate_hz)
    : max_step_mm_(limits.max_speed_mm_s / rate_hz), max_reach_mm_(limits.max_reach_mm) {}

bool MotionGuard::within_reach(const Vec3d& sample_mm) const {
  return sample_mm.allFinite() && sample_mm.cwiseAbs().maxCoeff() <= max_reach_mm_;
}

bool MotionGuard::judge(const Vec3d& sample_mm, Vec3d& used_mm) {
  const bool in_reach = within_reach(sample_mm);
  bool plausible = in_reach;
  if (in_reach && have_used_) {
    const double allowed_mm = max_step_mm_ * static_cast<double>(ticks_since_used_ + 1);
    const bool from_used = (sample_mm - last_used_mm_).norm() <= allowed_mm;
    const bool from_sample =
        last_sample_in_reach_ && (sample_mm - last_sample_mm_).norm() <= max_step_mm_;
    plausible = from_used || from_sample;
  }
  last_sample_mm_ = in_reach ? sample_mm : Vec3d::Zero();
  last_sample_in_reach_ = in_reach;
  if (!plausible) {
    ++faults_;
    ++ticks_since_used_;
    // Before any position was used there is none to hold: the device origin.
    used_mm = have_used_ ? last_used_mm_ : Vec3d::Zero();
    return true;
  }
  used_mm = sample_mm;
  last_used_mm_ = sample_mm;
  have_used_ = true;
  ticks_since_used_ = 0;
  return false;
}

bool run_force_stage(ForceStage& stage, Device& device, std::size_t tick,
                     const DeviceLimits& limits, ForceSafety& safety, TickRecord& row) {
  DeviceReading reading;
  device.read(tick, reading);
  const DeviceTransform& transform = device.transform();
  row.time_s = reading.time_s;
  row.device_position_mm = reading.position_mm;
  row.device_orientation_wxyz = reading.orientation_wxyz;
  // A sample no hand could have reached is not a position: the model stays where it was.
  Vec3d device_mm;
  const bool jumped = safety.motion.judge(reading.position_mm, device_mm);
  row.motion_fault = jumped ? 1 : 0;
  row.tool_position_mm = transform.apply(device_mm);
  row.holding = reading.holding ? 1 : 0;
  row.device_sequence = reading.sequence;
  const Vec3d model_force_n = stage.step(row.tool_position_mm, row);
  bool clamped = false;
  bool nonfinite = false;
  Vec3d force_n = safe_force(model_force_n, 1.0, limits, &clamped, &nonfinite);
  if (jumped || nonfinite) safety.fault();
  // After a fault the force falls from the last safe one; a new force is felt only as the
  // ramp brings it back in from zero, so a relocated tool cannot make a step either.
  if (safety.holding_force) force_n = safety.last_safe_force_n;
  safety.last_safe_force_n = force_n;
  row.force_scale = safety.ramp.next(reading.silent || reading.released);
  if (!safety.ramp.falling()) safety.holding_force = false;
  row.force_n = row.force_scale * force_n;
  row.clamped = clamped ? 1 : 0;
  // Forces go back to the device in its own frame (the scale moves points, not newtons).
  device.send(tick, transform.rotation.transpose() * row.force_n, row, nonfinite || jumped);
  return nonfinite;
}

}  // namespace hapvox::haptics
