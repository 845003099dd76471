// An incision in the proxy-FEM model (engine/proxy/incised_proxy.h through haptics/fem_model.h):
// the FEM holds the cut's two faces width apart in every step, a grab works on the incised
// body, and an incision can arrive in the middle of a run as a timed mesh change.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <set>

#include "engine/errors.h"
#include "engine/proxy/incised_proxy.h"
#include "fem_fixtures.h"
#include "haptics/fem_model.h"
#include "haptics/realtime.h"

namespace hapvox::haptics {
namespace {

using namespace fem_fixtures;

// The plane y = 5.3 across the block, from above its top (z = 8) down to z = 4.
engine::fem::CutSurface cut() {
  return engine::fem::swept_polyline({Vec3d(-1, 5.3, 9), Vec3d(13, 5.3, 9)}, Vec3d(0, 0, -5),
                                     "cut");
}

// The largest deviation, over the pairs, of plus - minus from width along +y.
double opening_error_mm(const engine::fem::TetMesh& mesh, const std::vector<double>& u,
                        double width_mm) {
  double worst = 0.0;
  std::set<int> seen;
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    // Pairs: two vertices at one rest point on the cut (y = 5.3).
    if (std::abs(mesh.rest_mm(1, v) - 5.3) > 1e-12) continue;
    for (int w = v + 1; w < mesh.vertex_count(); ++w) {
      if (mesh.rest_mm.col(w) != mesh.rest_mm.col(v)) continue;
      seen.insert(v);
      const Vec3d gap(u[3 * v] - u[3 * w], u[3 * v + 1] - u[3 * w + 1],
                      u[3 * v + 2] - u[3 * w + 2]);
      worst = std::max(worst, (gap - Vec3d(0, width_mm, 0)).norm());
    }
  }
  EXPECT_GT(seen.size(), 10u);
  return worst;
}

TEST(FemIncision, TheFemHoldsTheCutOpenInEveryStepWhileAGrabPulls) {
  const engine::proxy::ProxyMesh incised = engine::proxy::incise(block(), cut(), 2.0, "cut");
  const FemModel model(incised, options(FemInteraction::kGrab, 10));
  // The cut's vertices are held: a grab cannot capture them.
  std::vector<char> held(model.mesh().vertex_count(), 0);
  for (const auto& [dof, mm] : incised.prescribed_mm) held[dof / 3] = 1;
  for (const std::int32_t v : model.free_vertices()) EXPECT_FALSE(held[v]) << v;
  const FemRun run = run_lockstep(model, grab_path());
  ASSERT_FALSE(run.captured.empty());
  ASSERT_GT(run.frames.size(), 30u);
  // The first step (no load yet) is the static opening: K u = 0 with the faces prescribed.
  const Eigen::VectorXd loads = Eigen::VectorXd::Zero(3 * model.mesh().vertex_count());
  const Eigen::VectorXd opened = model.linear().solve_mm(loads, model.prescribed_mm());
  const std::vector<double>& first = run.frames.front().displacement_mm;
  for (int dof = 0; dof < opened.size(); ++dof) EXPECT_NEAR(first[dof], opened(dof), 1e-12) << dof;
  for (const FemFrame& frame : run.frames) {
    EXPECT_LT(opening_error_mm(model.mesh(), frame.displacement_mm, 2.0), 1e-12);
  }
  // The opening pushes the material beside the cut away from it: the top vertex at (2, 6, 8)
  // to +y, the one at (2, 4, 8) to -y (the block's vertices keep their lattice numbers).
  const auto lattice = [](int i, int j, int k) { return 3 * (i + 7 * (j + 7 * k)) + 1; };
  EXPECT_GT(first[lattice(1, 3, 4)], 0.1);
  EXPECT_LT(first[lattice(1, 2, 4)], -0.1);
  // And the grab still pulls: the force points back down.
  EXPECT_LT(run.force_n.back().z(), 0.0);
}

TEST(FemIncision, ATimedIncisionOpensTheCutInTheMiddleOfARun) {
  const FemModel model(block(), options(FemInteraction::kGrab, 10));
  LabelChange change;
  change.tick = 150;
  change.description = "incision cut";
  change.build_proxy = [] { return engine::proxy::incise(block(), cut(), 3.0, "cut"); };
  std::vector<LabelChange> changes;
  changes.push_back(change);
  const FemRun run = run_lockstep(model, grab_path(), std::move(changes));
  ASSERT_EQ(run.taken_ticks.size(), 1u);
  EXPECT_GE(run.taken_ticks[0], 150);
  int before = 0, after = 0;
  for (const FemFrame& frame : run.frames) {
    if (frame.mesh == 0) {
      ++before;
      EXPECT_LT(frame.tick, 150);
    } else {
      ++after;
      const engine::fem::TetMesh mesh =
          engine::proxy::incise(block(), cut(), 3.0, "cut").mesh;  // the same, deterministic
      EXPECT_LT(opening_error_mm(mesh, frame.displacement_mm, 3.0), 1e-12) << frame.tick;
    }
  }
  EXPECT_GT(before, 5);
  EXPECT_GT(after, 5);
  // The grab held on through the change.
  EXPECT_LT(run.force_n.back().z(), 0.0);
}

// ThreadSanitizer runs this one (FemRealtime.*): the cut built beside the FEM thread and
// taken over by it while the force thread reads snapshots.
TEST(FemRealtime, ATimedIncisionIsTakenOverByTheFemThreadAndHeldOpen) {
  const FemModel model(block(), options(FemInteraction::kGrab, 10));
  // 3 s: up 1 mm over 0.2 s from the top centre, then held, so that the cut's build (a
  // rebuild thread at nice 10: milliseconds alone, over 0.4 s under ThreadSanitizer beside
  // a compile) is taken over well before the end, as in the rebuild test.
  const Vec3d start(6.0, 6.0, kBlockTopMm);
  TraceDevice device = device_along(3000, [start](std::size_t k) {
    return Vec3d(start + Vec3d(0.0, 0.0, std::min(1.0, static_cast<double>(k) / 200.0)));
  });
  auto handoff = std::make_unique<FemHandoff>();
  FemForceStage force(model, *handoff);
  FemBackgroundStage fem(model, *handoff, device.tool_position_mm(0));
  LabelChange change;
  change.tick = 20;
  change.description = "incision cut";
  change.build_proxy = [] { return engine::proxy::incise(block(), cut(), 2.0, "cut"); };
  std::vector<LabelChange> changes;
  changes.push_back(change);
  fem.set_label_changes(std::move(changes));
  const ReplaySummary summary =
      replay_realtime(force, &fem, device, no_ramp(), nullptr, {}, nullptr, nullptr);
  EXPECT_EQ(summary.ticks, device.tick_count());
  EXPECT_EQ(force.counters().nonfinite_forces, 0u);
  ASSERT_EQ(fem.remeshes().size(), 1u);
  // Every step on the cut mesh holds it open.
  int cut_steps = 0;
  for (const FemFrame& frame : fem.frames()) {
    if (frame.mesh != 1) continue;
    ++cut_steps;
    EXPECT_LT(opening_error_mm(fem.model().mesh(), frame.displacement_mm, 2.0), 1e-12);
  }
  EXPECT_GT(cut_steps, 0);
}

TEST(FemIncision, AWidthThatIsNotPositiveIsAnInputError) {
  for (const double width : {0.0, -1.0, std::nan("")}) {
    try {
      engine::proxy::incise(block(), cut(), width, "cut.toml");
      ADD_FAILURE() << width;
    } catch (const InputError& e) {
      EXPECT_STREQ(e.what(), "cut.toml: the incision's width must be > 0 mm");
    }
  }
}

}  // namespace
}  // namespace hapvox::haptics
