// `hapvox render VOLUME --model fem --materials M.toml [--trace T]`: the frames of a lockstep
// FEM replay without a session, the same frames `replay --model fem --render-dir` draws.

#include <gtest/gtest.h>

#include <filesystem>

#include "render/image.h"
#include "test_data.h"

namespace hapvox {
namespace {

namespace fs = std::filesystem;
using testing::run_hapvox;
using testing::scratch_dir;
using testing::source_path;

// The four-sphere phantom at 2 mm (64^3), its grab trace, a coarse mesh: a few seconds.
std::string fem_flags() {
  return " --model fem --materials " + source_path("data/four_spheres.toml") +
         " --interaction grab --tool-diameter-mm 30 --spacing-mm 16 --boundary-levels 0"
         " --coupling-n-per-mm 1000";
}

TEST(RenderFem, DrawsTheFramesTheReplayDrawsAndTheGrabMovesTheSpheres) {
  const std::string dir = scratch_dir();
  const std::string volume = " four-spheres:dims=64,voxel_mm=2";
  const std::string trace = source_path("traces/fig5_grab.csv");
  const auto r = run_hapvox("render" + volume + fem_flags() + " --trace " + trace +
                            " --every-ticks 500 --size 96 --shadows -o " + dir + "/render");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("vertices grabbed"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(", shadows)"), std::string::npos) << r.out;
  // The replay of the same trace with the same flags (its render flags prefixed).
  const auto replay = run_hapvox("replay " + trace + " --volume" + volume + fem_flags() + " -o " +
                                 dir + "/s.h5 --render-dir " + dir +
                                 "/replay --render-every-ticks 500 --render-size 96 "
                                 "--render-shadows");
  ASSERT_EQ(replay.exit_code, 0) << replay.out << replay.err;
  int frames = 0;
  for (; fs::exists(dir + "/render/frame_000" + std::to_string(frames) + ".png"); ++frames) {
    const std::string name = "/frame_000" + std::to_string(frames) + ".png";
    ASSERT_TRUE(fs::exists(dir + "/replay" + name)) << name;
    EXPECT_EQ(render::read_png(dir + "/render" + name).rgba,
              render::read_png(dir + "/replay" + name).rgba)
        << name;
  }
  EXPECT_GE(frames, 3);  // ticks 0, 500, 1000 of the 1.5 s trace
  EXPECT_FALSE(fs::exists(dir + "/replay/frame_000" + std::to_string(frames) + ".png"));
  // The grab moved the spheres between the first frame and the last.
  EXPECT_LT(render::psnr_db(
                render::read_png(dir + "/render/frame_0000.png"),
                render::read_png(dir + "/render/frame_000" + std::to_string(frames - 1) + ".png")),
            40.0);
}

TEST(RenderFem, BadModelFlagsAreOneLineAndNoOutput) {
  const std::string dir = scratch_dir();
  struct Case {
    std::string args, error;
  };
  const std::vector<Case> cases = {
      {" --model finite", "hapvox: error: --model: expected voxel or fem, got 'finite'\n"},
      {" --model fem", "hapvox: error: --materials: --model fem needs one\n"},
      {" --materials " + source_path("data/four_spheres.toml"),
       "hapvox: error: --materials: needs --model fem\n"},
      {fem_flags() + " --trace " + source_path("traces/fig5_grab.csv") + " --plastic",
       "hapvox: error: --plastic: needs --model voxel (the FEM model does not sculpt)\n"},
      {" --model fem --materials " + source_path("data/four_spheres.toml") + " --interaction pinch",
       "hapvox: error: --interaction: unknown interaction 'pinch' (press or grab)\n"},
  };
  for (const Case& c : cases) {
    const auto r = run_hapvox("render four-spheres:dims=32" + c.args + " -o " + dir + "/frames");
    EXPECT_EQ(r.exit_code, 2) << c.args;
    EXPECT_EQ(r.err, c.error) << c.args;
    EXPECT_FALSE(fs::exists(dir + "/frames")) << c.args;
  }
}

}  // namespace
}  // namespace hapvox
