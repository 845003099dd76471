// The `hapvox render` and `hapvox bench render` commands end to end: frames written and
// looked at, one-line errors for bad input, nothing created before the input is valid.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "haptics/session.h"
#include "render/image.h"
#include "test_data.h"

namespace hapvox {
namespace {

namespace fs = std::filesystem;
using testing::run_hapvox;
using testing::run_hapvox_env;
using testing::scratch_dir;
using testing::source_path;

// Share of pixels that differ from the top-left (background) pixel.
double drawn_fraction(const render::Image& image) {
  std::size_t drawn = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      for (int c = 0; c < 3; ++c) {
        if (image.pixel(x, y)[c] != image.pixel(0, 0)[c]) {
          ++drawn;
          break;
        }
      }
    }
  }
  return static_cast<double>(drawn) / (image.width * image.height);
}

TEST(RenderCli, TurntableWritesFramesThatShowTheEngineFromEachSide) {
  const std::string dir = scratch_dir() + "/turn";  // created by the command
  const auto r = run_hapvox("render " + source_path("data/engine_256x256x128_uint8.nrrd") + " -o " +
                            dir + " --turntable 4 --size 128x96 --slices 128");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("wrote 4 frames of 128x96"), std::string::npos) << r.out;
  std::vector<render::Image> frames;
  for (int i = 0; i < 4; ++i) {
    frames.push_back(render::read_png(dir + "/frame_000" + std::to_string(i) + ".png"));
    EXPECT_EQ(frames.back().width, 128);
    EXPECT_EQ(frames.back().height, 96);
    EXPECT_GT(drawn_fraction(frames.back()), 0.1);
  }
  // A quarter turn apart, the views differ.
  EXPECT_LT(render::psnr_db(frames[0], frames[1]), 25.0);
}

TEST(RenderCli, TraceReplayDrawsTheToolPressingAndSculpting) {
  const std::string dir = scratch_dir();
  const auto r =
      run_hapvox("render block -o " + dir + "/clay --size 96 --slices 96 " + "--trace " +
                 source_path("traces/clay_stroke.csv") + " --plastic --every-ticks 2000 -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const int frames = static_cast<int>(
      std::distance(fs::directory_iterator(dir + "/clay"), fs::directory_iterator{}));
  EXPECT_GE(frames, 3);
  const render::Image first = render::read_png(dir + "/clay/frame_0000.png");
  const render::Image last =
      render::read_png(dir + "/clay/frame_000" + std::to_string(frames - 1) + ".png");
  // The groove left in the clay changes the last frame.
  EXPECT_LT(render::psnr_db(first, last), 40.0);
}

TEST(RenderCli, BadInputGivesOneLineNamingTheProblemAndCreatesNothing) {
  const std::string dir = scratch_dir();
  const std::string out = dir + "/frames";
  struct Case {
    std::string args, error;
  };
  const std::vector<Case> cases = {
      {"render " + dir + "/none.nrrd -o " + out, dir + "/none.nrrd: "},
      {"render block -o " + out + " --size 5",
       "--size: expected N or WxH with 16 <= N <= 8192, got '5'"},
      {"render block -o " + out + " --size 64xq", "--size: expected N or WxH"},
      {"render block -o " + out + " --slices 0", "--slices: must lie in [1, 4096]"},
      {"render block -o " + out + " --kernel gauss",
       "--kernel: expected wendland or paper, got 'gauss'"},
      {"render block -o " + out + " --tessellation x",
       "--tessellation: expected adaptive or uniform"},
      {"render block -o " + out + " --transfer nope", "nope: not a transfer-function preset"},
      {"render block -o " + out + " --plastic", "--plastic: needs --trace"},
      {"render block -o " + out + " --trace " + dir + "/none.csv", dir + "/none.csv: "},
      {"render block -o " + out + " --support-mm -1",
       "--support-mm: must lie in [0, 10000], not -1"},
      {"render block -o " + out + " --every-ticks 0", "--every-ticks: must lie in [1, 1e9], not 0"},
  };
  for (const Case& c : cases) {
    const auto r = run_hapvox(c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args;
    EXPECT_EQ(r.err.rfind("hapvox: error: " + c.error, 0), 0u) << c.args << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(out)) << c.args;
  }
  // An output path that is a file.
  std::ofstream(dir + "/file") << "x";
  const auto r = run_hapvox("render block -o " + dir + "/file");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "hapvox: error: " + dir + "/file: exists and is not a directory\n");
}

TEST(RenderCli, AMachineWithoutEglGetsAClearErrorAndNoOutput) {
  // glvnd with no vendor library: what a machine without Mesa's EGL looks like.
  const std::string dir = scratch_dir();
  const auto r = run_hapvox_env("__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent",
                                "render block -o " + dir + "/frames");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err,
            "hapvox: error: EGL: the surfaceless platform (EGL_MESA_platform_surfaceless) is not "
            "available; install Mesa's EGL (Debian: libegl-mesa0 libgl1-mesa-dri)\n");
  EXPECT_FALSE(fs::exists(dir + "/frames"));
  // And a replay asked to render writes no session either.
  const auto replay =
      run_hapvox_env("__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent",
                     "replay " + source_path("traces/engine_press.csv") + " --volume block -o " +
                         dir + "/s.h5 --render-dir " + dir + "/frames -q");
  EXPECT_EQ(replay.exit_code, 2);
  EXPECT_EQ(replay.err.rfind("hapvox: error: EGL: ", 0), 0u) << replay.err;
  EXPECT_FALSE(fs::exists(dir + "/s.h5"));
  EXPECT_FALSE(fs::exists(dir + "/s.h5.partial"));
}

TEST(RenderCli, LockstepReplayRendersEveryNTicks) {
  const std::string dir = scratch_dir();
  const auto r = run_hapvox("replay " + source_path("traces/engine_press.csv") + " --volume " +
                            source_path("data/engine_256x256x128_uint8.nrrd") + " -o " + dir +
                            "/s.h5 -q --render-dir " + dir + "/frames --render-every-ticks 1000 " +
                            "--render-size 64 --render-slices 64");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(haptics::read_session_info(dir + "/s.h5").complete);
  // Frames at ticks 0, 1000, 2000 and the last one.
  EXPECT_TRUE(fs::exists(dir + "/frames/frame_0003.png"));
  EXPECT_FALSE(fs::exists(dir + "/frames/frame_0004.png"));
  EXPECT_NE(r.out.find("render           4 frames"), std::string::npos) << r.out;
}

TEST(RenderCli, RealtimeReplayWithARenderThreadRecordsFrameTimes) {
  const std::string dir = scratch_dir();
  const auto r = run_hapvox("replay " + source_path("traces/clay_stroke.csv") +
                            " --volume block:dims=96 --plastic --realtime -q -o " + dir +
                            "/rt.h5 --render-dir " + dir + "/frames --render-size 64 " +
                            "--render-slices 48 --render-fps 10");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("render thread"), std::string::npos) << r.out;
  const auto frame_ns = haptics::read_session_column(dir + "/rt.h5", "/render/frame_ns");
  const auto ticks = haptics::read_session_column(dir + "/rt.h5", "/render/frame_tick");
  ASSERT_GE(frame_ns.size(), 5u);  // 6.4 s at up to 10 fps
  EXPECT_EQ(ticks.size(), frame_ns.size());
  for (std::size_t i = 1; i < ticks.size(); ++i) EXPECT_GE(ticks[i], ticks[i - 1]);
  // One PNG a frame.
  EXPECT_EQ(static_cast<std::size_t>(
                std::distance(fs::directory_iterator(dir + "/frames"), fs::directory_iterator{})),
            frame_ns.size());
}

TEST(RenderCli, BenchRenderPrintsOursBesideTheNaiveMeshWithPsnr) {
  const auto r =
      run_hapvox("bench render --volumes block:dims=64 --sizes 64 --frames 1 --slices 64");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("ours: adaptive, 64 slices"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("naive: 500 x 20x20, Eq. 10"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ours / naive"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("PSNR dB"), std::string::npos) << r.out;
  // The proxy-FEM rows: a grab that moved part of the 14^3 lattice, then the frames beside
  // the voxel model's.
  EXPECT_NE(r.out.find("fem: resampled, 64 slices"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("fem / voxel fps"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("fem + shadows"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("shadow volume in"), std::string::npos) << r.out;
  // The block hybrid beside the resample, and both per new displacement.
  EXPECT_NE(r.out.find("fem: block hybrid, 64 sl"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("blocks of 32^3 deformed"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("fem: new displacement + frame  resampled"), std::string::npos) << r.out;
  const auto moved = r.out.find(" of 13182 tets moved");
  ASSERT_NE(moved, std::string::npos) << r.out;
  const auto count_from = r.out.rfind(' ', moved - 1) + 1;
  const int moved_tets = std::stoi(r.out.substr(count_from, moved - count_from));
  EXPECT_GT(moved_tets, 0) << r.out;
  EXPECT_LT(moved_tets, 13182) << r.out;  // the bump fades: the far tets stay put
}

// Issue 8 point 6: the bundled volume is found wherever hapvox runs from (here a fresh
// directory with no data/ in it), as bench render's default names it.
TEST(RenderCli, BenchRenderFindsTheBundledVolumeFromAnyWorkingDirectory) {
  const std::string dir = scratch_dir();
  ASSERT_FALSE(fs::exists(dir + "/data"));
  // run_hapvox_env puts its first argument before the command: change directory there.
  const auto r = run_hapvox_env("cd " + dir + " &&",
                                "bench render --volumes data/engine_256x256x128_uint8.nrrd "
                                "--sizes 16 --frames 1 --slices 16");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.find("cannot open"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("engine_256x256x128_uint8.nrrd"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ours / naive"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace hapvox
