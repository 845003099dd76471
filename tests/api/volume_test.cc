// hapvox::Volume and hapvox::Trace (api/volume.cc, api/trace.cc): arrays in and out, files
// round trip, bad input in the command line's words.

#include <filesystem>

#include "api_testing.h"

namespace hapvox::testing {
namespace {

TEST(ApiVolume, DensitiesRoundTripThroughAnArrayAndAFile) {
  const std::array<int, 3> dims = {5, 4, 3};
  std::vector<float> density(60);
  for (std::size_t i = 0; i < density.size(); ++i) density[i] = static_cast<float>(i % 7) / 6.0f;
  const Volume volume = Volume::from_densities(density, dims, {0.5, 1.0, 2.0}, {10.0, 20.0, 30.0});
  EXPECT_EQ(volume.dims(), dims);
  EXPECT_EQ(volume.densities(), density);
  EXPECT_EQ(volume.spacing_mm(), (std::array<double, 3>{0.5, 1.0, 2.0}));
  EXPECT_EQ(volume.origin_mm(), (std::array<double, 3>{10.0, 20.0, 30.0}));
  // Voxel faces: half a voxel beyond the first and last centres.
  EXPECT_EQ(volume.world_min_mm(), (std::array<double, 3>{9.75, 19.5, 29.0}));
  EXPECT_EQ(volume.world_max_mm(), (std::array<double, 3>{12.25, 23.5, 35.0}));
  const std::string dir = scratch_dir();
  for (const char* ext : {".nrrd", ".vdb"}) {
    const std::string path = dir + "/v" + ext;
    volume.save(path);
    const Volume back = Volume::load(path);
    EXPECT_EQ(back.densities(), density) << ext;
    EXPECT_EQ(back.dims(), dims) << ext;
    EXPECT_EQ(back.origin_mm(), volume.origin_mm()) << ext;
    EXPECT_EQ(input_error_of([&] { back.save(path); }),
              path + ": would overwrite the volume it was read from");
  }
}

TEST(ApiVolume, BadArraysAndFilesSayWhatIsWrong) {
  EXPECT_EQ(input_error_of([] {
              Volume::from_densities({0.5f}, {2, 1, 1});
            }),
            "array: 1 densities for dims 2x1x1 (2 voxels)");
  EXPECT_EQ(input_error_of([] {
              Volume::from_densities({0.5f, 1.5f}, {2, 1, 1});
            }),
            "array: density 1.500000 at index 1 is outside [0, 1]");
  EXPECT_EQ(input_error_of([] {
              Volume::from_densities({0.5f}, {1, 1, 1}, {0.0, 1.0, 1.0});
            }),
            "array: spacing_mm must be positive");
  const std::string missing = "/nonexistent/none.nrrd";
  const CommandResult run = run_hapvox("info " + missing);
  EXPECT_EQ(input_error_of([&] { Volume::load(missing); }), cli_error_line(run));
  IntensityOptions window;
  window.window = std::array<double, 2>{5.0, 1.0};
  EXPECT_EQ(input_error_of([&] { Volume::load("block", window); }), "--window: HI must exceed LO");
}

TEST(ApiTrace, SamplesRoundTripAndResampleOntoTheLoopsClock) {
  const Trace trace = Trace::from_samples({0.0, 0.01}, {{{0.0, 0.0, 0.0}}, {{10.0, -20.0, 5.0}}});
  const std::vector<ToolSample> ticks = trace.resampled(1000.0);
  ASSERT_EQ(ticks.size(), 11u);
  EXPECT_DOUBLE_EQ(ticks[5].position_mm[0], 5.0);
  EXPECT_DOUBLE_EQ(ticks[5].position_mm[1], -10.0);
  EXPECT_DOUBLE_EQ(ticks[10].position_mm[2], 5.0);
  const std::string dir = scratch_dir();
  for (const char* ext : {".csv", ".h5"}) {
    const std::string path = dir + "/t" + ext;
    trace.save(path);
    const Trace back = Trace::load(path);
    EXPECT_EQ(back.time_s(), trace.time_s()) << ext;
    EXPECT_EQ(back.position_mm(), trace.position_mm()) << ext;
  }
  EXPECT_EQ(input_error_of([] {
              Trace::from_samples({0.0, 0.0}, {{}, {}});
            }),
            "trace: time is not strictly increasing at sample 1");
  EXPECT_EQ(input_error_of([] { Trace::from_samples({0.0}, {{}}); }),
            "trace: needs at least two samples");
  TraceColumns columns;
  columns.time_unit = "hours";
  const CommandResult run = run_hapvox("replay " + source_path(kEnginePress) +
                                       " --volume block -q -o " + dir + "/x.h5 --time-unit hours");
  EXPECT_EQ(input_error_of([&] { Trace::load(source_path(kEnginePress), columns); }),
            cli_error_line(run));
}

TEST(ApiSession, NamesItsDatasetsAndRefusesOnesItHasNot) {
  const std::string dir = scratch_dir();
  const Session session = cli_replay(dir, kEnginePress, kEngineCt);
  EXPECT_TRUE(session.complete());
  const Dataset& force = session.dataset("force_n");
  EXPECT_EQ(force.shape, (std::vector<std::size_t>{session.rows(), 3}));
  EXPECT_EQ(session.dataset("/time_s").shape, (std::vector<std::size_t>{session.rows()}));
  EXPECT_EQ(input_error_of([&] { session.dataset("nope"); }), session.path() + ": no dataset nope");
  const std::string missing = dir + "/none.h5";
  EXPECT_EQ(input_error_of([&] { Session::open(missing); }), missing + ": cannot open file");
  EXPECT_EQ(std::string(version()), HAPVOX_VERSION_STRING);
}

}  // namespace
}  // namespace hapvox::testing
