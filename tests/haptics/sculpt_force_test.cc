// What a hand feels while sculpting, through the whole lockstep pipeline (force stage,
// deletion, relaxation, publication): plastic unloading on the way up, and a steady force
// along a steady stroke.

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <cstdio>
#include <memory>
#include <numbers>
#include <utility>
#include <vector>

#include "engine/relax.h"
#include "engine/volume_io.h"
#include "haptics/replay.h"
#include "haptics/session.h"
#include "haptics/voxel_model.h"
#include "test_data.h"

namespace hapvox::haptics {
namespace {

struct SculptTicks {
  std::vector<double> time_s;
  std::vector<Vec3d> position_mm, force_n;
  std::vector<double> event, deleted;
  SculptSummary sculpt;
};

std::vector<Vec3d> triples(const std::vector<double>& flat) {
  std::vector<Vec3d> out(flat.size() / 3);
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = Vec3d(flat[3 * i], flat[3 * i + 1], flat[3 * i + 2]);
  return out;
}

// A perfectly plastic lockstep replay of `make` on a clay block of 1 mm voxels.
SculptTicks sculpt(const TraceMakeOptions& make, double diameter_mm, double friction = 0.5) {
  engine::DensityField field = engine::generate_volume("block:dims=64");  // face z = 31.5
  engine::ToolForceOptions options;
  options.tool.diameter_mm = diameter_mm;
  options.plastic.enabled = true;
  options.plastic.yield_stress_pa = 8e3;  // mean contact pressure at which the clay flows
  options.friction_coefficient = friction;
  const engine::ToolForceModel model(field, options);
  engine::MassGrid mass(field);
  SurfaceChangeChannel channel;
  SculptContext context;
  context.mass = &mass;
  context.mirror = &field;
  context.channel = &channel;
  TraceDevice device(resample(make_trace(make)), DeviceTransform{});
  const std::string path = testing::scratch_dir() + "/sculpt.h5";
  SculptTicks out;
  {
    SessionWriter session(path);
    replay_lockstep(model, device, DeviceLimits{}, &session, {}, &context, &out.sculpt);
    session.close();
  }
  out.time_s = read_session_column(path, "/time_s");
  out.position_mm = triples(read_session_column(path, "/tool_position_mm"));
  out.force_n = triples(read_session_column(path, "/force_n"));
  out.event = read_session_column(path, "/plastic/event");
  out.deleted = read_session_column(path, "/relax/deleted_voxels");
  return out;
}

TEST(SculptForce, PressAndReleaseFlowsOnlyOnTheWayDownAndNeverPullsTheToolIn) {
  TraceMakeOptions make;
  make.shape = TraceShape::kPressRelease;
  make.start_mm = Vec3d(32.2, 31.7, 31.5 + 5.0 + 1.0);  // 1 mm above the face
  make.travel_mm = 4.0;                                 // 3 mm into the clay
  make.speed_mm_s = 10.0;
  make.hold_s = 0.1;
  const SculptTicks run = sculpt(make, 10.0);
  ASSERT_GT(run.sculpt.plastic_events, 100u);
  // The turning point: the last tick at the bottom, where the tool starts back up. Loading
  // is judged by the stress, so the hold at the bottom may still flow while the deletions
  // of the last plastic ticks reach the field and shrink the contact; the way up never does.
  std::size_t turn = 0;
  for (std::size_t i = 0; i < run.position_mm.size(); ++i) {
    if (run.position_mm[i].z() <= run.position_mm[turn].z()) turn = i;
  }
  ASSERT_GT(turn, 100u);
  double events_after = 0, deleted_before = 0, deleted_after = 0;
  for (std::size_t i = 0; i < run.event.size(); ++i) {
    (i > turn ? deleted_after : deleted_before) += run.deleted[i];
    if (i > turn) events_after += run.event[i];
    // The clay lies below (+z is out of it): never a force into the material.
    ASSERT_GE(run.force_n[i].z(), 0.0) << "tick " << i;
  }
  EXPECT_EQ(events_after, 0.0);
  EXPECT_GT(deleted_before, 0.0);
  // Deletions queued by the last plastic ticks may land a few ticks after the turn; none
  // comes from the way up.
  double deleted_late = 0;
  for (std::size_t i = turn + 20; i < run.deleted.size(); ++i) deleted_late += run.deleted[i];
  EXPECT_EQ(deleted_late, 0.0);
}

// Amplitude of the Fourier component at frequency f_hz of samples x (sampled at rate_hz),
// over a whole number of periods.
double amplitude_at(const std::vector<double>& x, double f_hz, double rate_hz) {
  std::complex<double> sum = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sum +=
        x[i] * std::polar(1.0, -2.0 * std::numbers::pi * f_hz * static_cast<double>(i) / rate_hz);
  }
  return 2.0 * std::abs(sum) / static_cast<double>(x.size());
}

TEST(SculptForce, SteadyStrokeForceHasNoRippleAtTheVoxelCrossingFrequency) {
  // 10 mm/s through 1 mm voxels: a voxel crossed every 0.1 s (10 Hz). Frictionless, |F| is
  // the normal force the yield rule holds at sigma_f pi a^2; with Coulomb friction the
  // spring's stick phases lag that force's own ripple and add to |F|'s (measured 0.57 % at
  // mu = 0, 1.00 % at 0.5).
  for (const auto& [friction, bound] : {std::pair{0.0, 0.01}, std::pair{0.5, 0.015}}) {
    TraceMakeOptions make;
    make.shape = TraceShape::kStroke;
    make.start_mm = Vec3d(12.3, 31.6, 31.5 + 5.0 + 1.0);
    make.travel_mm = 3.0;  // 2 mm into the clay
    make.speed_mm_s = 10.0;
    make.stroke_length_mm = 36.0;
    const SculptTicks run = sculpt(make, 10.0, friction);
    const double bottom_z = make.start_mm.z() - make.travel_mm;
    // The stroke's steady part: at the bottom, after 10 mm of travel (the bow wave has
    // formed), a whole number of crossing periods (2 s = 20 voxels).
    std::vector<double> magnitude;
    double flowing = 0;
    for (std::size_t i = 0; i < run.position_mm.size(); ++i) {
      const Vec3d& p = run.position_mm[i];
      if (std::abs(p.z() - bottom_z) > 1e-9 || p.x() < make.start_mm.x() + 10.0) continue;
      magnitude.push_back(run.force_n[i].norm());
      flowing += run.event[i];
      if (magnitude.size() == 2000) break;
    }
    ASSERT_EQ(magnitude.size(), 2000u);
    // The tool ploughs: the clay flows on most ticks of the stroke.
    EXPECT_GT(flowing, 0.5 * magnitude.size());
    double mean = 0;
    for (double f : magnitude) mean += f;
    mean /= magnitude.size();
    ASSERT_GT(mean, 0.05);
    const double ripple = amplitude_at(magnitude, 10.0, 1000.0);
    std::printf("stroke, mu %.1f: mean %.4f N, 10 Hz amplitude %.5f N (%.2f %%), 20 Hz %.5f N\n",
                friction, mean, ripple, 100.0 * ripple / mean,
                amplitude_at(magnitude, 20.0, 1000.0));
    EXPECT_LE(ripple, bound * mean) << "mu " << friction << ", mean " << mean << " N";
    // Its harmonics are as small.
    EXPECT_LE(amplitude_at(magnitude, 20.0, 1000.0), bound * mean) << friction;
  }
}

}  // namespace
}  // namespace hapvox::haptics
