// Rebuilding the proxy-FEM model in the middle of a run (haptics/fem_remesh.h): a rebuild of
// the same mesh changes no force; a rebuild onto another mesh, with more of it fixed, gives
// from then on the forces and displacements of a run on that mesh from the start (linear
// statics: the state is the grab's offset alone); and in realtime the build runs beside the
// FEM thread, which keeps stepping the old model until it is done (ThreadSanitizer runs
// FemRealtime.*).

#include "haptics/fem_remesh.h"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "engine/errors.h"
#include "fem_fixtures.h"
#include "haptics/realtime.h"

namespace hapvox::haptics {
namespace {

using namespace fem_fixtures;

// The same 12 x 12 x 8 mm block on a 4/3 mm lattice, its lowest two layers fixed: another
// mesh and more of it held.
engine::proxy::ProxyMesh fine_block() {
  engine::proxy::ProxyMesh proxy;
  const double spacing_mm = 4.0 / 3.0;
  proxy.mesh = engine::fem::regular_lattice({10, 10, 7}, spacing_mm, Vec3d::Zero(), 1);
  proxy.materials.assign(proxy.mesh.tet_count(), {kYoungsPa, kPoisson});
  for (int v = 0; v < proxy.mesh.vertex_count(); ++v) {
    proxy.vertex_classes.push_back(
        proxy.mesh.rest_mm(2, v) <= spacing_mm + 1e-9 ? VertexClass::kFixed : VertexClass::kFree);
  }
  proxy.materials_source = "fine test block";
  return proxy;
}

LabelChange change_at(std::int64_t tick, std::function<engine::proxy::ProxyMesh()> build) {
  return LabelChange{tick, "test change", std::move(build)};
}

TEST(FemRemesh, RebuildingTheSameMeshMidGrabChangesNoForce) {
  const FemModel model(block(), options(FemInteraction::kGrab, 10));
  TraceDevice device = grab_path();
  const FemRun plain = run_lockstep(model, device);
  const FemRun rebuilt = run_lockstep(model, device, {change_at(250, block)});
  ASSERT_EQ(rebuilt.taken_ticks, std::vector<std::int64_t>{259});  // the FEM step after 250
  const double peak = peak_n(plain.force_n);
  ASSERT_GT(peak, 0.1);
  for (std::size_t k = 0; k < plain.force_n.size(); ++k) {
    ASSERT_LE((plain.force_n[k] - rebuilt.force_n[k]).norm(), 1e-9 * peak) << "tick " << k;
  }
  ASSERT_EQ(plain.frames.size(), rebuilt.frames.size());
  for (std::size_t s = 0; s < plain.frames.size(); ++s) {
    EXPECT_EQ(rebuilt.frames[s].mesh, plain.frames[s].tick >= 259 ? 1 : 0);
    for (std::size_t i = 0; i < plain.frames[s].displacement_mm.size(); ++i) {
      ASSERT_NEAR(plain.frames[s].displacement_mm[i], rebuilt.frames[s].displacement_mm[i], 1e-9)
          << "step " << s;
    }
  }
}

TEST(FemRemesh, AfterARebuildOntoAnotherMeshTheRunIsOneOnThatMeshFromTheStart) {
  const FemOptions o = options(FemInteraction::kGrab, 10);
  const FemModel coarse(block(), o);
  const FemModel fine(fine_block(), o);
  TraceDevice device = grab_path();
  const FemRun on_fine = run_lockstep(fine, device);
  const FemRun on_coarse = run_lockstep(coarse, device);
  const FemRun switched = run_lockstep(coarse, device, {change_at(250, fine_block)});
  ASSERT_EQ(switched.taken_ticks, std::vector<std::int64_t>{259});
  ASSERT_EQ(switched.captured, on_fine.captured);
  const double peak = peak_n(on_fine.force_n);
  // Before: the coarse run's forces; the two meshes' forces differ (another capture, held
  // two layers up), or this test could not tell them apart.
  for (std::size_t k = 0; k < 250; ++k) {
    ASSERT_EQ(switched.force_n[k], on_coarse.force_n[k]) << "tick " << k;
  }
  EXPECT_GT((on_fine.force_n[399] - on_coarse.force_n[399]).norm(),
            0.05 * on_coarse.force_n[399].norm());
  // From the tick after the step that took it over: the fine run's.
  for (std::size_t k = 260; k < device.tick_count(); ++k) {
    ASSERT_LE((switched.force_n[k] - on_fine.force_n[k]).norm(), 1e-9 * peak) << "tick " << k;
  }
  for (std::size_t s = 0; s < switched.frames.size(); ++s) {
    if (switched.frames[s].mesh == 0) continue;
    ASSERT_EQ(switched.frames[s].tick, on_fine.frames[s].tick);
    for (std::size_t i = 0; i < on_fine.frames[s].displacement_mm.size(); ++i) {
      ASSERT_NEAR(switched.frames[s].displacement_mm[i], on_fine.frames[s].displacement_mm[i], 1e-9)
          << "step " << s;
    }
  }
}

TEST(FemRemesh, ACorotationalRunCarriesItsShapeAndLoadsOverARebuild) {
  // The co-rotational solver steps from the old field, interpolated at the new mesh's
  // vertices, under the loads that hold it (its elastic forces): a run switched to the same
  // mesh stays the plain run but for one warping step's residual (the elastic forces of a
  // single stiffness-warping step are not quite the loads it was given). Starting the new
  // mesh from no load instead is off by 1 % of the peak.
  FemOptions o = options(FemInteraction::kGrab, 10);
  o.solver = FemSolver::kCorotational;
  const FemModel model(block(), o);
  TraceDevice device = grab_path();
  const FemRun plain = run_lockstep(model, device);
  const FemRun rebuilt = run_lockstep(model, device, {change_at(250, block)});
  const double peak = peak_n(plain.force_n);
  double largest = 0.0;
  for (std::size_t k = 0; k < plain.force_n.size(); ++k) {
    largest = std::max(largest, (plain.force_n[k] - rebuilt.force_n[k]).norm());
  }
  // 1e-4 of the peak measured; the difference dies out as the warping steps go on.
  EXPECT_LE(largest, 1e-3 * peak);
  EXPECT_LE((plain.force_n.back() - rebuilt.force_n.back()).norm(), 1e-8 * peak);
}

TEST(FemRemesh, ABuildThatFailsStopsTheRunWithItsError) {
  const FemModel model(block(), options(FemInteraction::kGrab, 10));
  const LabelChange bad = change_at(100, []() -> engine::proxy::ProxyMesh {
    throw InputError("materials.toml", "label 7 has no material");
  });
  try {
    run_lockstep(model, grab_path(), {bad});
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "materials.toml: label 7 has no material");
  }
}

TEST(FemRealtime, ARebuildRunsBesideTheFemThreadWhichStepsTheOldMeshUntilItIsDone) {
  const FemOptions o = options(FemInteraction::kGrab, 10);
  const FemModel model(block(), o);
  // 3 s: up 1 mm over 0.2 s from the top centre, then held. The build (a 300 ms sleep and a
  // small mesh, at nice 10) has 2.6 s to finish: enough under ThreadSanitizer on a busy
  // machine (1.4 s was not, with a compile beside it).
  const Vec3d start(6.0, 6.0, kBlockTopMm);
  TraceDevice device = device_along(3000, [start](std::size_t k) {
    return Vec3d(start + Vec3d(0.0, 0.0, std::min(1.0, static_cast<double>(k) / 200.0)));
  });
  auto handoff = std::make_unique<FemHandoff>();
  FemForceStage force(model, *handoff);
  FemBackgroundStage fem(model, *handoff, device.tool_position_mm(0));
  constexpr std::int64_t kChangeTick = 100;
  constexpr auto kSlowBuild = std::chrono::milliseconds(300);  // a mesher that takes its time
  fem.set_label_changes({change_at(kChangeTick, [&] {
    std::this_thread::sleep_for(kSlowBuild);
    return fine_block();
  })});
  TimingSummary timing;
  const ReplaySummary summary =
      replay_realtime(force, &fem, device, no_ramp(), nullptr, {}, nullptr, &timing);
  EXPECT_EQ(summary.ticks, device.tick_count());
  EXPECT_EQ(force.counters().nonfinite_forces, 0u);
  ASSERT_EQ(fem.remeshes().size(), 1u);
  const FemRemesh& remesh = *fem.remeshes()[0];
  EXPECT_GE(remesh.build_s, 0.3);
  // Taken over at least the build's length after the change was due...
  EXPECT_GE(remesh.taken_tick, kChangeTick + 300);
  // ...while the FEM thread stepped the old mesh (100 Hz: about 30 steps; a few on any
  // machine) and the force thread kept its ticks.
  int old_steps_during_build = 0;
  for (const FemFrame& frame : fem.frames()) {
    if (frame.mesh == 0 && frame.tick > kChangeTick) ++old_steps_during_build;
    if (frame.tick > remesh.taken_tick) {
      EXPECT_EQ(frame.mesh, 1);
    }
  }
  EXPECT_GE(old_steps_during_build, 3);
  EXPECT_EQ(&fem.model(), remesh.model.get());
  EXPECT_EQ(fem.displacement_mm().size(), 3 * fem.model().mesh().vertex_count());
}

}  // namespace
}  // namespace hapvox::haptics
