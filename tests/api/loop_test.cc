// The loops behind the API (api/loop.cc): run_lockstep, run_realtime and ForceStage run the
// force stage `hapvox replay` runs, so for the same positions they give its forces bit for
// bit; a callback device gets each force in its own frame; a step allocates nothing.

#include <cmath>

#include "alloc_count.h"
#include "alloc_counter.h"
#include "api_testing.h"

namespace hapvox::testing {
namespace {

Dataset forces_of(const std::vector<ForceTick>& ticks) {
  Dataset d;
  d.shape = {ticks.size(), 3};
  for (const ForceTick& t : ticks)
    d.values.insert(d.values.end(), t.force_n.begin(), t.force_n.end());
  return d;
}

std::vector<ForceTick> step_through(const Model& model, const std::vector<ToolSample>& samples) {
  ForceStage stage(model);
  std::vector<ForceTick> ticks;
  for (const ToolSample& s : samples) ticks.push_back(stage.step(s));
  return ticks;
}

TEST(ApiForceStage, StepsTheForcesOfALockstepReplayBitForBit) {
  const Session cli = cli_replay(scratch_dir(), kEnginePress, kEngineCt);
  const Model model = Model::voxel(Volume::load(source_path(kEngineCt)));
  const std::vector<ToolSample> samples = Trace::load(source_path(kEnginePress)).resampled();
  ASSERT_EQ(samples.size(), cli.rows());
  const std::vector<ForceTick> ticks = step_through(model, samples);
  EXPECT_TRUE(same_bits(forces_of(ticks), cli.dataset("force_n")));
  // One model, a second stage: the same forces (the model is constant).
  EXPECT_TRUE(same_bits(forces_of(step_through(model, samples)), cli.dataset("force_n")));
}

TEST(ApiForceStage, SculptsAsALockstepReplaySculpts) {
  const char* flags = "--plastic --yield-stress-pa 2000 --tool-diameter-mm 8";
  const Session cli = cli_replay(scratch_dir(), kEnginePress, kEngineCt, flags);
  ModelOptions options;
  options.plastic = true;
  options.yield_stress_pa = 2000.0;
  options.tool_diameter_mm = 8.0;
  const Model model = Model::voxel(Volume::load(source_path(kEngineCt)), options);
  const std::vector<ToolSample> samples = Trace::load(source_path(kEnginePress)).resampled();
  EXPECT_TRUE(same_bits(forces_of(step_through(model, samples)), cli.dataset("force_n")));
  // The press did sculpt (else this would test the elastic path again).
  double deleted = 0.0;
  for (double d : cli.dataset("relax/deleted_voxels").values) deleted += d;
  EXPECT_GT(deleted, 0.0);
}

TEST(ApiForceStage, AStepAllocatesNothing) {
  const Model model = Model::voxel(Volume::load(source_path(kEngineCt)));
  const std::vector<ToolSample> samples = Trace::load(source_path(kEnginePress)).resampled();
  ForceStage stage(model);
  const std::uint64_t before = allocations_on_this_thread;
  double peak = 0.0;
  for (const ToolSample& s : samples) peak = std::max(peak, std::abs(stage.step(s).force_n[2]));
  EXPECT_EQ(allocations_on_this_thread, before);
  EXPECT_GT(peak, 0.1);  // it touched: the contact path ran
  EXPECT_EQ(stage.ticks(), samples.size());
}

TEST(ApiLoop, ALockstepRunOfATraceWritesTheReplaysSession) {
  const std::string dir = scratch_dir();
  const Session cli = cli_replay(dir, kEnginePress, kEngineCt, "--max-force-n 1.5");
  const Model model = Model::voxel(Volume::load(source_path(kEngineCt)));
  Device device = Device::trace(Trace::load(source_path(kEnginePress)));
  LoopOptions options;
  options.max_force_n = 1.5;
  options.session_path = dir + "/run.h5";
  const RunSummary summary = run_lockstep(model, device, options);
  const Session api = Session::open(options.session_path);
  EXPECT_TRUE(same_bits(api.dataset("force_n"), cli.dataset("force_n")));
  EXPECT_TRUE(same_bits(api.dataset("tool_position_mm"), cli.dataset("tool_position_mm")));
  EXPECT_EQ(summary.ticks, cli.rows());
  EXPECT_GT(summary.clamped_ticks, 0u);  // the 1.5 N limit bit
  EXPECT_LE(summary.peak_force_n, 1.5 + 1e-12);
}

TEST(ApiLoop, ACallbackDeviceGetsEachForceInItsOwnFrame) {
  const Model model = Model::voxel(Volume::load("block"));
  // The block generator's clay fills the lower half of its box; the device frame is turned
  // 90 degrees about x, so the device's +y is the volume's +z.
  const Volume& volume = model.volume();
  const auto lo = volume.world_min_mm();
  const auto hi = volume.world_max_mm();
  const double cx = 0.5 * (lo[0] + hi[0]);
  const double cy = 0.5 * (lo[1] + hi[1]);
  const double top = 0.5 * (lo[2] + hi[2]);
  DeviceTransform transform;
  transform.rotate_deg = {90.0, 0.0, 0.0};
  std::vector<std::array<double, 3>> sent;
  const std::size_t ticks = 400;
  Device device = Device::callback(
      [&](std::size_t tick) {
        // Device (x, y, z) -> volume (x, -z, y): press 3 mm down into the top along -y_dev.
        const double depth = 3.0 * static_cast<double>(tick) / ticks;
        ToolSample s;
        s.time_s = 1e-3 * static_cast<double>(tick);
        s.position_mm = {cx, top + model.tool_radius_mm() - depth, -cy};
        return s;
      },
      ticks, 1000.0, transform,
      [&](std::size_t, const std::array<double, 3>& f) { sent.push_back(f); });
  LoopOptions options;
  options.session_path = scratch_dir() + "/cb.h5";
  run_lockstep(model, device, options);
  ASSERT_EQ(sent.size(), ticks);
  const Session session = Session::open(options.session_path);
  const Dataset& force = session.dataset("force_n");
  // The block pushes back up (+z in the volume): +y in the device frame.
  EXPECT_GT(force.values[3 * (ticks - 1) + 2], 0.1);
  for (std::size_t k = 0; k < ticks; ++k) {
    const double* f = &force.values[3 * k];
    EXPECT_NEAR(sent[k][0], f[0], 1e-12);
    EXPECT_NEAR(sent[k][1], f[2], 1e-12);   // device y = volume z
    EXPECT_NEAR(sent[k][2], -f[1], 1e-12);  // device z = -volume y
  }
}

TEST(ApiLoop, ARealtimeRunComputesTheLockstepForces) {
  const Model model = Model::voxel(Volume::load(source_path(kEngineCt)));
  const Trace trace = Trace::load(source_path(kEnginePress));
  const std::string dir = scratch_dir();
  LoopOptions options;
  options.session_path = dir + "/lockstep.h5";
  Device lockstep_device = Device::trace(trace);
  run_lockstep(model, lockstep_device, options);
  options.session_path = dir + "/realtime.h5";
  Device realtime_device = Device::trace(trace);
  const RunSummary summary = run_realtime(model, realtime_device, options);
  EXPECT_EQ(summary.ticks, trace.resampled().size());
  const Session lockstep = Session::open(dir + "/lockstep.h5");
  const Session realtime = Session::open(options.session_path);
  // Same positions, same model: the same forces unless a watchdog trip ramped one down.
  if (summary.watchdog_trips == 0) {
    EXPECT_TRUE(same_bits(realtime.dataset("force_n"), lockstep.dataset("force_n")));
  }
  EXPECT_TRUE(
      same_bits(realtime.dataset("tool_position_mm"), lockstep.dataset("tool_position_mm")));
}

// Nakao's Fig. 6 on a coarse mesh: the engine's right end grabbed, its left part fixed by the
// materials file. The command line refines the mesh along the trace's path unless told not
// to; a Model knows no path ahead.
const char* const kGrabFlags[] = {"--interaction",     "grab",  "--coupling-n-per-mm", "1000",
                                  "--max-force-n",     "10000", "--spacing-mm",        "16",
                                  "--boundary-levels", "0"};

Model grab_model() {
  ModelOptions options;
  options.materials = source_path("data/engine_grab.toml");
  options.tool_diameter_mm = 24.0;
  options.flags.assign(std::begin(kGrabFlags), std::end(kGrabFlags));
  return Model::fem(Volume::load(source_path(kEngineCt)), options);
}

TEST(ApiForceStage, StepsTheFemModelAsALockstepReplayDoes) {
  std::string flags = "--model fem --no-tool-refine --tool-diameter-mm 24 --materials " +
                      source_path("data/engine_grab.toml");
  for (const char* flag : kGrabFlags) flags += std::string(" ") + flag;
  const std::string dir = scratch_dir();
  const Session cli = cli_replay(dir, "traces/engine_grab.csv", kEngineCt, flags);
  const Model model = grab_model();
  EXPECT_EQ(model.tool_radius_mm(), 12.0);
  const Trace trace = Trace::load(source_path("traces/engine_grab.csv"));
  LoopOptions options;
  options.max_force_n = 10000.0;
  ForceStage stage(model, options);
  std::vector<ForceTick> ticks;
  for (const ToolSample& s : trace.resampled()) ticks.push_back(stage.step(s));
  EXPECT_TRUE(same_bits(forces_of(ticks), cli.dataset("force_n")));
  // The grab pulled: a force, and the mesh moved.
  double peak = 0.0;
  for (double f : cli.dataset("force_n").values) peak = std::max(peak, std::abs(f));
  EXPECT_GT(peak, 1.0);

  // run_lockstep writes the FEM's steps as the replay does.
  options.session_path = dir + "/api.h5";
  Device device = Device::trace(trace);
  run_lockstep(model, device, options);
  const Session api = Session::open(options.session_path);
  EXPECT_TRUE(same_bits(api.dataset("force_n"), cli.dataset("force_n")));
  EXPECT_TRUE(same_bits(api.dataset("fem/displacement_mm"), cli.dataset("fem/displacement_mm")));
  EXPECT_TRUE(same_bits(api.dataset("fem/step_time_s"), cli.dataset("fem/step_time_s")));
}

TEST(ApiModel, TheFemModelsBadInputIsTheCommandLines) {
  const Volume ct = Volume::load(source_path(kEngineCt));
  EXPECT_EQ(input_error_of([&] { Model::fem(ct, {}); }), "--materials: --model fem needs one");
  ModelOptions options;
  options.materials = source_path("data/engine_grab.toml");
  options.plastic = true;
  EXPECT_EQ(input_error_of([&] { Model::fem(ct, options); }),
            "--plastic: needs --model voxel (the FEM model does not sculpt)");
  const Volume array = Volume::from_densities({1.0f}, {1, 1, 1});
  EXPECT_EQ(input_error_of([&] { Model::fem(array, {}); }),
            "array: the proxy-FEM model reads its labels from a volume file or generator: save "
            "the array (Volume::save) and load that");
  options.plastic = false;
  options.model = "fem";
  EXPECT_EQ(input_error_of([&] { Model::voxel(ct, options); }),
            "--model: Model::voxel makes the voxel model: use Model::fem");
}

TEST(ApiLoop, BadLoopOptionsAreTheCommandLinesErrors) {
  const Model model = Model::voxel(Volume::load("block"));
  Device device = Device::trace(Trace::load(source_path(kEnginePress)));
  LoopOptions options;
  options.max_force_n = 0.0;
  EXPECT_EQ(input_error_of([&] { run_lockstep(model, device, options); }),
            "--max-force-n: must lie in (0, 1e6], not 0");
  options = {};
  options.ramp_in_s = -1.0;
  EXPECT_EQ(input_error_of([&] { ForceStage stage(model, options); }),
            "--ramp-in-s: must lie in [0, 60], not -1");
  EXPECT_EQ(input_error_of([&] { Device::callback({}, 10); }), "device: no read callback");
  EXPECT_EQ(
      input_error_of([&] { Device::callback([](std::size_t) { return ToolSample{}; }, 10, 0.0); }),
      "--rate-hz: must be in (0, 100000]");
}

}  // namespace
}  // namespace hapvox::testing
