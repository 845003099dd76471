// The proxy-FEM model's stages (haptics/fem_model.h) through the loops: the grab force equals
// a full FEM solve with the captured vertices held, whatever the FEM's rate; the press is
// continuous, pushes the tool out of the material, and does not depend on how often the FEM
// runs while the contact set stays; lockstep runs are bit-identical; and the realtime FEM
// thread hands its snapshots over without a race (ThreadSanitizer runs FemRealtime.*).

#include "haptics/fem_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <memory>
#include <thread>
#include <vector>

#include "engine/errors.h"
#include "engine/fem/tet_mesh.h"
#include "fem_fixtures.h"
#include "haptics/realtime.h"
#include "haptics/replay.h"
#include "haptics/session.h"
#include "test_data.h"

namespace hapvox::haptics {
namespace {

using engine::fem::VertexClass;
using namespace fem_fixtures;

TEST(FemGrab, ForceEqualsAFullSolveWithTheCapturedVerticesHeldAtAnyFemRate) {
  const FemModel every_tick(block(), options(FemInteraction::kGrab, 1));
  const FemModel every_ten(block(), options(FemInteraction::kGrab, 10));
  TraceDevice device = grab_path();
  const FemRun fast = run_lockstep(every_tick, device);
  const FemRun slow = run_lockstep(every_ten, device);
  ASSERT_EQ(fast.captured.size(), 6u);
  const double peak = peak_n(fast.force_n);
  ASSERT_GT(peak, 0.1);
  for (std::size_t k = 0; k < fast.force_n.size(); ++k) {
    ASSERT_LE((fast.force_n[k] - slow.force_n[k]).norm(), 1e-9 * peak) << "tick " << k;
  }
  // The full solve: the captured vertices prescribed at the proxy's offset d; the body's
  // pull on them is what the coupling balances, so the device feels the sum of the
  // support reactions, negated. The proxy is p = p_d + F / k_c.
  const FemOptions& o = every_tick.options();
  std::vector<int> held = every_tick.fixed_dofs();
  for (const int v : engine::fem::vertex_dofs(fast.captured)) held.push_back(v);
  const engine::fem::LinearFem full(every_tick.mesh(), every_tick.proxy().materials, held);
  for (const std::size_t k : {50u, 199u, 300u, 399u}) {
    const Vec3d proxy = device.tool_position_mm(k) + fast.force_n[k] / o.coupling_n_per_mm;
    const Vec3d d = proxy - device.tool_position_mm(0);
    Eigen::VectorXd prescribed = Eigen::VectorXd::Zero(3 * every_tick.mesh().vertex_count());
    for (const std::int32_t v : fast.captured) prescribed.segment<3>(3 * v) = d;
    const Eigen::VectorXd loads = Eigen::VectorXd::Zero(prescribed.size());
    const Eigen::VectorXd reactions = full.reactions_n(full.solve_mm(loads, prescribed), loads);
    Vec3d held_by_tool = Vec3d::Zero();
    for (const std::int32_t v : fast.captured) held_by_tool += reactions.segment<3>(3 * v);
    EXPECT_LE((fast.force_n[k] + held_by_tool).norm(), 1e-9 * peak) << "tick " << k;
  }
  // Pulled up and sideways, the material pulls the tool back down and back.
  EXPECT_LT(fast.force_n.back().z(), 0.0);
  EXPECT_LT(fast.force_n.back().x(), 0.0);
}

// From the top centre, `travel_mm` along +x over 200 ticks, then held for 200.
TraceDevice sideways_grab_path(double travel_mm) {
  const Vec3d start(6.0, 6.0, kBlockTopMm);
  return device_along(400, [start, travel_mm](std::size_t k) {
    return Vec3d(start + Vec3d(travel_mm * std::min(1.0, static_cast<double>(k) / 200.0), 0, 0));
  });
}

TEST(FemCorotational, ASmallGrabFeelsLikeLinearAndALargeOneStaysDisplacementControlled) {
  FemOptions linear = options(FemInteraction::kGrab, 10);
  FemOptions corotational = linear;
  corotational.solver = FemSolver::kCorotational;
  // 0.02 mm: rotations of order 1e-3, so the warped stiffness is the linear one to about
  // that; a stage that used W or the loads wrongly in this mode would differ at O(1).
  TraceDevice small = sideways_grab_path(0.02);
  const FemRun lin = run_lockstep(FemModel(block(), linear), small);
  const FemRun cor = run_lockstep(FemModel(block(), corotational), small);
  ASSERT_EQ(cor.captured, lin.captured);
  ASSERT_GT(lin.force_n.back().norm(), 1e-4);
  EXPECT_LE((cor.force_n.back() - lin.force_n.back()).norm(), 0.01 * lin.force_n.back().norm())
      << cor.force_n.back().transpose() << " vs " << lin.force_n.back().transpose();
  // 3 mm through a stiff coupling: the captured vertices end where the proxy is (the
  // co-rotational loads are corrected by their remaining offset each FEM step), the
  // material pulls back along -x, and the held vertices never move.
  corotational.coupling_n_per_mm = 1000.0;
  const FemModel model(block(), corotational);
  TraceDevice large = sideways_grab_path(3.0);
  const FemRun run = run_lockstep(model, large);
  const Vec3d proxy = large.tool_position_mm(399) + run.force_n.back() / 1000.0;
  const Vec3d offset = proxy - large.tool_position_mm(0);
  EXPECT_GT(offset.x(), 2.9);
  EXPECT_LT(run.force_n.back().x(), 0.0);
  for (const std::int32_t v : run.captured) {
    const Vec3d u(&run.frames.back().displacement_mm[3 * static_cast<std::size_t>(v)]);
    EXPECT_LE((u - offset).norm(), 0.01 * offset.norm()) << "vertex " << v;
  }
  for (const int dof : model.fixed_dofs()) {
    EXPECT_EQ(run.frames.back().displacement_mm[static_cast<std::size_t>(dof)], 0.0);
  }
}

// A 4 mm sphere from 0.5 mm above the top face to 1 mm into it, at 1 mm/s.
TraceDevice press_path() {
  return device_along(1500, [](std::size_t k) {
    const double depth_mm = -0.5 + 1.5 * static_cast<double>(k) / 1499.0;
    return Vec3d(6.0, 6.0, kBlockTopMm + 4.0 - depth_mm);
  });
}

TEST(FemPress, ForceIsContinuousPushesOutAndDoesNotDependOnTheFemRate) {
  const FemModel every_tick(block(), options(FemInteraction::kPress, 1));
  const FemModel every_ten(block(), options(FemInteraction::kPress, 10));
  TraceDevice device = press_path();
  const FemRun fast = run_lockstep(every_tick, device);
  const FemRun slow = run_lockstep(every_ten, device);
  const double peak = peak_n(fast.force_n);
  ASSERT_GT(peak, 0.05);
  double largest_jump = 0.0;
  for (std::size_t k = 0; k < fast.force_n.size(); ++k) {
    ASSERT_LE((fast.force_n[k] - slow.force_n[k]).norm(), 1e-9 * peak) << "tick " << k;
    if (k > 0)
      largest_jump = std::max(largest_jump, (fast.force_n[k] - fast.force_n[k - 1]).norm());
    // Frictionless on a symmetric block: up, out of the material; sideways only by the
    // Kuhn lattice's diagonals (measured 0.35 % of the peak).
    EXPECT_GE(fast.force_n[k].z(), 0.0);
    EXPECT_LE(std::hypot(fast.force_n[k].x(), fast.force_n[k].y()), 0.01 * peak);
  }
  EXPECT_LE(largest_jump, 0.05 * peak);
  EXPECT_EQ(fast.contact.front(), 0);
  EXPECT_EQ(fast.contact.back(), 1);
  // Deeper is harder.
  EXPECT_GT(fast.force_n.back().z(), fast.force_n[1000].z());
}

TEST(FemContact, OneVertexPressIsTwoSpringsInSeries) {
  // A vertex at the origin with compliance c = 0.5 mm/N, a sphere of r = 2 mm whose centre
  // the device puts delta = 0.3 mm too close above it, a coupling of k_c = 2 N/mm: the
  // vertex and the coupling are springs in series, lambda = delta / (c + 1 / k_c) = 0.3 N,
  // and at the proxy the vertex sits exactly on the sphere.
  auto snapshot = std::make_unique<ContactSnapshot>();
  snapshot->count = 2;
  snapshot->vertices = {0, 1};
  snapshot->base_mm[0] = Vec3d::Zero();
  snapshot->base_mm[1] = Vec3d(10, 0, 0);  // out of reach
  snapshot->w_mm_per_n.topLeftCorner(6, 6).setIdentity();
  snapshot->w_mm_per_n.topLeftCorner(6, 6) *= 0.5;
  const double radius = 2.0, delta = 0.3, coupling = 2.0;
  const Vec3d device(0, 0, radius - delta);
  PressScratch scratch;
  const ContactSolve solve = solve_press(*snapshot, device, device, radius, coupling, scratch);
  ASSERT_TRUE(solve.converged);
  EXPECT_EQ(solve.active, 1);
  EXPECT_NEAR(solve.lambda_n[0], delta / (0.5 + 1.0 / coupling), 1e-14);
  EXPECT_EQ(solve.lambda_n[1], 0.0);
  EXPECT_NEAR(solve.force_n.z(), 0.3, 1e-14);  // up, out of the material
  EXPECT_NEAR(solve.force_n.x(), 0.0, 1e-14);
  const Vec3d vertex = snapshot->base_mm[0] + 0.5 * solve.lambda_n[0] * solve.normal[0];
  EXPECT_NEAR((vertex - solve.proxy_mm).norm(), radius, 1e-14);
}

// The device 9.5 mm below the surface: the soft coupling lets it sink more than twice the
// tool radius (4 mm) while the proxy stays near the surface (about 3 mm in at the end).
TEST(FemPress, ADeepPressStillPushesOutAndHarderTheDeeper) {
  FemOptions o = options(FemInteraction::kPress, 10);
  o.coupling_n_per_mm = 0.2;
  const FemModel model(block(), o);
  TraceDevice device = device_along(1200, [](std::size_t k) {
    const double depth_mm = -0.5 + 10.0 * static_cast<double>(k) / 1199.0;
    return Vec3d(6.0, 6.0, kBlockTopMm + 4.0 - depth_mm);
  });
  const FemRun run = run_lockstep(model, device);
  for (std::size_t k = 0; k < run.force_n.size(); ++k) {
    ASSERT_GE(run.force_n[k].z(), 0.0) << "tick " << k;
  }
  EXPECT_GT(run.force_n.back().z(), run.force_n[800].z());
  EXPECT_GT(run.force_n[800].z(), run.force_n[400].z());
}

TEST(FemPress, TwoLockstepRunsAreBitIdentical) {
  const FemModel model(block(), options(FemInteraction::kPress, 10));
  TraceDevice device = press_path();
  const FemRun a = run_lockstep(model, device);
  const FemRun b = run_lockstep(model, device);
  ASSERT_EQ(a.frames.size(), b.frames.size());
  for (std::size_t k = 0; k < a.force_n.size(); ++k) {
    ASSERT_EQ(std::memcmp(a.force_n[k].data(), b.force_n[k].data(), sizeof(Vec3d)), 0);
  }
  for (std::size_t s = 0; s < a.frames.size(); ++s) {
    ASSERT_EQ(a.frames[s].displacement_mm, b.frames[s].displacement_mm);
  }
  EXPECT_EQ(a.frames.size(), 1 + 1500 / 10);
}

// A live session has no known length: past FemOptions::kept_steps_mb the steps kept for the
// session are thinned to every 2nd, 4th, ... step over the whole run (and the last), each
// exactly the step an unthinned run made; the forces do not change.
TEST(FemPress, StepsOverTheirMemoryBudgetAreThinnedEvenlyAndKeepTheLast) {
  const FemModel every_step(block(), options(FemInteraction::kPress, 10));
  FemOptions budgeted = options(FemInteraction::kPress, 10);
  budgeted.kept_steps_mb = 0.05;  // 50 kB: 8 of the block's 245-vertex steps (5880 bytes)
  const FemModel thinned_model(block(), budgeted);
  TraceDevice device = press_path();
  const FemRun all = run_lockstep(every_step, device);
  const FemRun thinned = run_lockstep(thinned_model, device);
  ASSERT_EQ(all.frames.size(), 1 + 1500 / 10);
  ASSERT_EQ(thinned.force_n, all.force_n);
  ASSERT_GE(thinned.frames.size(), 3u);
  const std::uint64_t every = thinned.frames[1].step;  // the thinning's stride
  ASSERT_GT(every, 1u);
  EXPECT_EQ(every & (every - 1), 0u) << every;  // a power of two
  const std::uint64_t last_step = all.frames.back().step;
  std::vector<std::uint64_t> expected;
  for (std::uint64_t step = 0; step <= last_step; step += every) expected.push_back(step);
  if (expected.back() != last_step) expected.push_back(last_step);
  std::vector<std::uint64_t> kept;
  for (const FemFrame& frame : thinned.frames) {
    kept.push_back(frame.step);
    const FemFrame& same = all.frames[frame.step];
    ASSERT_EQ(same.step, frame.step);
    ASSERT_EQ(same.tick, frame.tick);
    ASSERT_EQ(same.displacement_mm, frame.displacement_mm) << frame.step;
  }
  EXPECT_EQ(kept, expected);
  // Within the budget, and thinned no further than it needed: every (every / 2)-th would not fit.
  const double frame_bytes = 8.0 * all.frames[0].displacement_mm.size();
  EXPECT_LE(frame_bytes * static_cast<double>(thinned.frames.size()), 0.05e6);
  EXPECT_GT(frame_bytes * static_cast<double>(last_step / (every / 2) + 2), 0.05e6);
}

TEST(FemOptionsCheck, BadOptionsAreInputErrors) {
  FemOptions o;
  o.tool_radius_mm = 0.0;
  try {
    validate(o);
    FAIL();
  } catch (const hapvox::InputError& e) {
    EXPECT_STREQ(e.what(), "fem options: the tool radius must be > 0 mm");
  }
  o = FemOptions{};
  o.coupling_n_per_mm = NAN;
  EXPECT_THROW(validate(o), hapvox::InputError);
  EXPECT_THROW(parse_fem_interaction("poke", "--interaction"), hapvox::InputError);
  EXPECT_EQ(parse_fem_solver("corotational", "--fem-solver"), FemSolver::kCorotational);
}

TEST(FemGrab, NothingWithinReachIsAnInputErrorNamingTheNearestVertex) {
  const FemModel model(block(), options(FemInteraction::kGrab, 10));
  FemHandoff handoff;
  EXPECT_THROW(FemBackgroundStage(model, handoff, Vec3d(6, 6, 20)), hapvox::InputError);
}

TEST(FemRealtime, TheFemThreadStepsBesideTheForceThreadAndItsForcesAreFinite) {
  const FemModel model(block(), options(FemInteraction::kPress, 10));
  TraceDevice device = press_path();
  auto handoff = std::make_unique<FemHandoff>();
  FemForceStage force(model, *handoff);
  FemBackgroundStage fem(model, *handoff, device.tool_position_mm(0));
  TimingSummary timing;
  const ReplaySummary summary =
      replay_realtime(force, &fem, device, no_ramp(), nullptr, {}, nullptr, &timing);
  EXPECT_EQ(summary.ticks, device.tick_count());
  // 1.5 s at 100 Hz; however loaded the machine, several steps.
  EXPECT_GE(fem.steps(), 5u);
  EXPECT_EQ(fem.frames().size(), fem.steps());
  EXPECT_GT(summary.peak_force_n, 0.05);
  EXPECT_EQ(force.counters().nonfinite_forces, 0u);
}

// sculpt's FEM segments: the FEM paced in lockstep with the realtime force loop (each step
// after its tick, before the next) steps exactly as a lockstep run, and every step reaches
// the render thread through the feed.
TEST(FemRealtime, PacedInLockstepItStepsAsTheLockstepRunAndFeedsTheRenderThread) {
  const FemModel model(block(), options(FemInteraction::kPress, 10));
  TraceDevice device = press_path();
  const FemRun lockstep = run_lockstep(model, device);
  auto handoff = std::make_unique<FemHandoff>();
  FemForceStage force(model, *handoff);
  FemBackgroundStage fem(model, *handoff, device.tool_position_mm(0));
  RealtimeOptions realtime;
  realtime.scheduler.lock_memory = false;
  realtime.background_in_lockstep = true;
  std::vector<FemFrame> drawn;  // the steps the render thread saw, in order
  realtime.render_loop = [&drawn](RenderFeed& feed, RenderTiming&) {
    while (true) {
      const bool done = feed.done.load(std::memory_order_acquire);
      const MeshDisplacement& latest = feed.mesh.read();
      if (latest.tick >= 0 && (drawn.empty() || drawn.back().tick != latest.tick)) {
        drawn.push_back({latest.tick, latest.displacement_mm, latest.mesh_index});
      }
      if (done) break;
      std::this_thread::sleep_for(std::chrono::microseconds(300));
    }
  };
  const std::string path = testing::scratch_dir() + "/paced.h5";
  SessionWriter session(path);
  const ReplaySummary summary =
      replay_realtime(force, &fem, device, no_ramp(), &session, {}, nullptr, nullptr, realtime);
  session.close();
  ASSERT_EQ(summary.ticks, device.tick_count());
  ASSERT_EQ(fem.frames().size(), lockstep.frames.size());
  for (std::size_t k = 0; k < lockstep.frames.size(); ++k) {
    ASSERT_EQ(fem.frames()[k].tick, lockstep.frames[k].tick) << k;
    ASSERT_EQ(fem.frames()[k].displacement_mm, lockstep.frames[k].displacement_mm) << k;
  }
  // The same force wherever the loop sent it unramped (a watchdog trip on a loaded machine
  // ramps a tick, never changes what it computed); the press is felt.
  const std::vector<double> force_n = read_session_column(path, "/force_n");
  const std::vector<double> scale = read_session_column(path, "/force_scale");
  std::size_t compared = 0;
  for (std::size_t k = 0; k < scale.size(); ++k) {
    if (scale[k] != 1.0) continue;
    ++compared;
    for (int a = 0; a < 3; ++a) ASSERT_EQ(force_n[3 * k + a], lockstep.force_n[k][a]) << k;
  }
  EXPECT_GT(compared, 100u);
  EXPECT_GT(peak_n(lockstep.force_n), 0.05);
  // The render thread saw FEM steps (not only the first, begin()'s, which the paced loop does
  // not hand over), each exactly as the step made it, and the last one at the end.
  ASSERT_GE(drawn.size(), 2u);
  for (const FemFrame& step : drawn) {
    const std::size_t k = static_cast<std::size_t>(step.tick + 1) / 10;
    ASSERT_LT(k, lockstep.frames.size());
    ASSERT_EQ(lockstep.frames[k].tick, step.tick);
    ASSERT_EQ(lockstep.frames[k].displacement_mm, step.displacement_mm) << step.tick;
  }
  EXPECT_EQ(drawn.back().tick, lockstep.frames.back().tick);
}

}  // namespace
}  // namespace hapvox::haptics
