#pragma once
// The proxy-FEM stages' test fixtures (tests/haptics/fem_*_test.cc): a small fixed-bottom
// block, devices along a path, and a lockstep run that keeps every row.

#include <algorithm>
#include <functional>
#include <memory>
#include <vector>

#include "engine/fem/tet_mesh.h"
#include "haptics/fem_model.h"
#include "haptics/replay.h"

namespace hapvox::haptics::fem_fixtures {

using engine::fem::VertexClass;

constexpr double kYoungsPa = 1e5;  // 0.1 MPa
constexpr double kPoisson = 0.3;
constexpr double kBlockTopMm = 8.0;

// A 12 x 12 x 8 mm block of 2 mm Kuhn cells, its bottom face fixed.
inline engine::proxy::ProxyMesh block() {
  engine::proxy::ProxyMesh proxy;
  proxy.mesh = engine::fem::regular_lattice({7, 7, 5}, 2.0, Vec3d::Zero(), 1);
  proxy.materials.assign(proxy.mesh.tet_count(), {kYoungsPa, kPoisson});
  for (int v = 0; v < proxy.mesh.vertex_count(); ++v) {
    proxy.vertex_classes.push_back(proxy.mesh.rest_mm(2, v) == 0.0 ? VertexClass::kFixed
                                                                   : VertexClass::kFree);
  }
  proxy.materials_source = "test block";
  return proxy;
}

// A 1 kHz device following `path(tick)` for `ticks` ticks.
inline TraceDevice device_along(std::size_t ticks, const std::function<Vec3d(std::size_t)>& path) {
  ResampledTrace trace;
  for (std::size_t k = 0; k < ticks; ++k) {
    trace.time_s.push_back(static_cast<double>(k) / trace.rate_hz);
    trace.position_mm.push_back(path(k));
    trace.holding.push_back(0);
  }
  return TraceDevice(std::move(trace), DeviceTransform{});
}

inline DeviceLimits no_ramp() {
  DeviceLimits limits;
  limits.max_force_n = 1e3;
  limits.ramp_in_s = 0.0;
  return limits;
}

struct FemRun {
  std::vector<Vec3d> force_n;
  std::vector<std::uint8_t> contact;
  std::vector<FemFrame> frames;
  std::vector<std::int32_t> captured;
  std::vector<std::int64_t> taken_ticks;  // of each remesh
  std::uint64_t unconverged = 0;          // press solves the force stage could not finish
};

// A lockstep run of `device` through the FEM stages, recording every row.
inline FemRun run_lockstep(const FemModel& model, TraceDevice device,
                           std::vector<LabelChange> changes = {}) {
  // The order replay_lockstep runs them in, with every row kept.
  FemRun run;
  auto handoff2 = std::make_unique<FemHandoff>();
  FemForceStage force2(model, *handoff2);
  FemBackgroundStage fem2(model, *handoff2, device.tool_position_mm(0));
  fem2.set_label_changes(std::move(changes));
  fem2.begin();
  ForceSafety safety(no_ramp(), device.rate_hz());
  for (std::size_t tick = 0; tick < device.tick_count(); ++tick) {
    TickRecord row;
    run_force_stage(force2, device, tick, no_ramp(), safety, row);
    fem2.run_lockstep_tick(tick, row, nullptr);
    run.force_n.push_back(row.force_n);
    run.contact.push_back(row.contact);
  }
  run.frames = fem2.frames();
  run.captured = fem2.captured_vertices();
  for (const auto& remesh : fem2.remeshes()) run.taken_ticks.push_back(remesh->taken_tick);
  run.unconverged = force2.unconverged_solves();
  return run;
}

inline double peak_n(const std::vector<Vec3d>& forces) {
  double peak = 0.0;
  for (const Vec3d& f : forces) peak = std::max(peak, f.norm());
  return peak;
}

inline FemOptions options(FemInteraction interaction, std::size_t every_ticks) {
  FemOptions o;
  o.interaction = interaction;
  o.fem_every_ticks = every_ticks;
  o.coupling_n_per_mm = 1.0;
  if (interaction == FemInteraction::kGrab) {
    o.tool_radius_mm = 2.1;  // the top-centre vertex and its five lattice neighbours
  } else {
    o.tool_radius_mm = 4.0;
    o.candidate_margin_mm = 1.0;
  }
  return o;
}

// Up 1 mm, then 1 mm along +x, from the top centre.
inline TraceDevice grab_path() {
  const Vec3d start(6.0, 6.0, kBlockTopMm);
  return device_along(400, [start](std::size_t k) {
    const double s = static_cast<double>(k) / 200.0;
    return Vec3d(start + Vec3d(std::max(0.0, s - 1.0), 0.0, std::min(s, 1.0)));
  });
}

}  // namespace hapvox::haptics::fem_fixtures
