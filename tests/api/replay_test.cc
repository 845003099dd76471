// hapvox::replay and run_sweep_row (api/replay.cc) run `hapvox replay`'s own code: the same
// session, the same error lines.

#include <filesystem>
#include <fstream>

#include "api_testing.h"

namespace hapvox::testing {
namespace {

// Physics columns: everything but the wall-clock ones (compute_ns).
const char* const kPhysics[] = {"time_s",
                                "device_position_mm",
                                "tool_position_mm",
                                "force_n",
                                "displacement_mm",
                                "contact_area_mm2",
                                "contact",
                                "clamped",
                                "force_scale",
                                "plastic/strain",
                                "plastic/stress_pa",
                                "relax/total_mass_units",
                                "relax/deleted_voxels",
                                "relax/relaxed_voxels"};

void expect_same_physics(const Session& api, const Session& cli) {
  ASSERT_EQ(api.rows(), cli.rows());
  for (const char* name : kPhysics) {
    if (!cli.has_dataset(name)) continue;
    EXPECT_TRUE(same_bits(api.dataset(name), cli.dataset(name))) << name;
  }
}

TEST(ApiReplay, ASessionEqualsTheCommandLinesBitForBit) {
  const Session cli =
      cli_replay(scratch_dir(), kEnginePress, kEngineCt, "--tool-diameter-mm 6 --poisson 0.25");
  ReplayOptions options;
  options.volume = source_path(kEngineCt);
  options.trace = source_path(kEnginePress);
  options.model.tool_diameter_mm = 6.0;
  options.model.poisson_ratio = 0.25;
  const Session api = replay(options);
  EXPECT_TRUE(api.path().empty());  // a temporary session, read back and removed
  expect_same_physics(api, cli);
  // The forces are not all zero: the press touches.
  double peak = 0.0;
  for (double f : api.dataset("force_n").values) peak = std::max(peak, std::abs(f));
  EXPECT_GT(peak, 0.1);
  EXPECT_EQ(api.attribute("tool_diameter_mm"), cli.attribute("tool_diameter_mm"));
}

TEST(ApiReplay, TheFemModelWithItsMaterialsIsTheCommandLinesToo) {
  // Nakao's Fig. 6 on a coarse mesh: the engine's right end grabbed, its left part fixed
  // by the materials file.
  const char* const fem_flags[] = {"--interaction",     "grab",  "--coupling-n-per-mm", "1000",
                                   "--max-force-n",     "10000", "--spacing-mm",        "16",
                                   "--boundary-levels", "0"};
  std::string cli_flags =
      "--model fem --materials " + source_path("data/engine_grab.toml") + " --tool-diameter-mm 24";
  for (const char* flag : fem_flags) cli_flags += std::string(" ") + flag;
  const std::string dir = scratch_dir();
  const Session cli = cli_replay(dir, "traces/engine_grab.csv", kEngineCt, cli_flags);
  ReplayOptions options;
  options.volume = source_path(kEngineCt);
  options.trace = source_path("traces/engine_grab.csv");
  options.model.model = "fem";
  options.model.materials = source_path("data/engine_grab.toml");
  options.model.tool_diameter_mm = 24.0;
  options.model.flags.assign(std::begin(fem_flags), std::end(fem_flags));
  const Session api = replay(options);
  expect_same_physics(api, cli);
  ASSERT_TRUE(cli.has_dataset("fem/displacement_mm"));
  EXPECT_TRUE(same_bits(api.dataset("fem/displacement_mm"), cli.dataset("fem/displacement_mm")));
  // The grab moved the mesh.
  double moved = 0.0;
  for (double u : api.dataset("fem/displacement_mm").values) moved = std::max(moved, std::abs(u));
  EXPECT_GT(moved, 1.0);
}

TEST(ApiReplay, WritesTheSessionWhereAsked) {
  const std::string output = scratch_dir() + "/api.h5";
  ReplayOptions options;
  options.volume = "block";
  options.trace = source_path(kEnginePress);
  options.output = output;
  options.flags = {"--fit"};
  const Session session = replay(options);
  EXPECT_EQ(session.path(), output);
  EXPECT_TRUE(std::filesystem::exists(output));
  EXPECT_TRUE(session.complete());
}

TEST(ApiReplay, BadInputIsTheCommandLinesErrorLine) {
  const std::string dir = scratch_dir();
  const std::string bad_trace = dir + "/bad.csv";
  std::ofstream(bad_trace) << "t,x,y,z\n0,1,2,3\n0.001,1,2\n";
  const std::string volume = source_path(kEngineCt);
  struct Case {
    std::string flags;
    std::function<void(ReplayOptions&)> set;
  };
  const Case cases[] = {
      {"--poisson 0.7", [](ReplayOptions& o) { o.model.poisson_ratio = 0.7; }},
      {"--tool-diameter-mm -2", [](ReplayOptions& o) { o.model.tool_diameter_mm = -2.0; }},
      {"--model clay", [](ReplayOptions& o) { o.model.model = "clay"; }},
      {"--spacing-mm 4",
       [](ReplayOptions& o) {
         o.model.flags = {"--spacing-mm", "4"};
       }},
  };
  for (const Case& c : cases) {
    const CommandResult run = run_hapvox("replay " + source_path(kEnginePress) + " --volume " +
                                         volume + " -q -o " + dir + "/x.h5 " + c.flags);
    ASSERT_EQ(run.exit_code, 2) << c.flags;
    ReplayOptions options;
    options.volume = volume;
    options.trace = source_path(kEnginePress);
    c.set(options);
    EXPECT_EQ(input_error_of([&] { replay(options); }), cli_error_line(run)) << c.flags;
  }
  // A bad trace file: the CLI names the file and the line.
  const CommandResult run =
      run_hapvox("replay " + bad_trace + " --volume " + volume + " -q -o " + dir + "/y.h5");
  ASSERT_EQ(run.exit_code, 2);
  ReplayOptions options;
  options.volume = volume;
  options.trace = bad_trace;
  const std::string message = input_error_of([&] { replay(options); });
  EXPECT_EQ(message, cli_error_line(run));
  EXPECT_NE(message.find(bad_trace), std::string::npos);
}

TEST(ApiReplay, ASweepRowIsTheReplayTheSweepRunsForIt) {
  const std::string dir = scratch_dir();
  const std::string manifest = dir + "/sweep.toml";
  std::ofstream(manifest) << "traces = [\"" << source_path(kEnginePress) << "\"]\nvolumes = [\""
                          << source_path(kEngineCt)
                          << "\"]\n[options]\ntool-diameter-mm = [4, 8]\n";
  const Session row1 = run_sweep_row(manifest, 1);
  const Session cli = cli_replay(dir, kEnginePress, kEngineCt, "--tool-diameter-mm 8");
  expect_same_physics(row1, cli);
  EXPECT_EQ(input_error_of([&] { run_sweep_row(manifest, 2); }),
            manifest + ": has 2 rows, no row 2");
}

}  // namespace
}  // namespace hapvox::testing
