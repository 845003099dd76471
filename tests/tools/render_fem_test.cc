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
      {" --incision " + source_path("data/engine_incision.toml"),
       "hapvox: error: --incision: needs --model fem\n"},
      {fem_flags() + " --incision " + dir + "/none.toml",
       "hapvox: error: " + dir + "/none.toml: cannot open file\n"},
      // The engine's cut lies beside the 32 mm phantom: nothing of it is on the cut.
      {fem_flags() + " --incision " + source_path("data/engine_incision.toml"),
       "hapvox: error: " + source_path("data/engine_incision.toml") +
           ": the cut crosses no element of the mesh\n"},
  };
  for (const Case& c : cases) {
    const auto r = run_hapvox("render four-spheres:dims=32" + c.args + " -o " + dir + "/frames");
    EXPECT_EQ(r.exit_code, 2) << c.args;
    EXPECT_EQ(r.err, c.error) << c.args;
    EXPECT_FALSE(fs::exists(dir + "/frames")) << c.args;
  }
}

// The engine seen from the front (x to the right, z up) at rest and with
// data/engine_incision.toml's cut (x = 165 mm, from the top down to z = 50 mm, 8 mm open).
std::string engine_front(const std::string& extra, const std::string& out) {
  return "render " + source_path("data/engine_256x256x128_uint8.nrrd") +
         " --model fem --materials " + source_path("data/engine_grab.toml") +
         " --spacing-mm 16 --boundary-levels 0 --size 320x240 --azimuth-deg -90 --elevation-deg 0" +
         extra + " -o " + out;
}

TEST(RenderFem, AnIncisionOpensASlotYouSeeThroughAndLeavesTheFixedPartAlone) {
  const std::string dir = scratch_dir();
  const auto whole = run_hapvox(engine_front("", dir + "/whole"));
  ASSERT_EQ(whole.exit_code, 0) << whole.out << whole.err;
  const auto cut = run_hapvox(
      engine_front(" --incision " + source_path("data/engine_incision.toml"), dir + "/cut"));
  ASSERT_EQ(cut.exit_code, 0) << cut.out << cut.err;
  EXPECT_NE(cut.out.find("no trace: the volume at rest, the incision opened\n"), std::string::npos)
      << cut.out;
  EXPECT_NE(cut.out.find("vertices held open 8 mm wide\n"), std::string::npos) << cut.out;
  const render::Image a = render::read_png(dir + "/whole/frame_0000.png");
  const render::Image b = render::read_png(dir + "/cut/frame_0000.png");
  ASSERT_EQ(a.width, 320);
  const auto pixel = [](const render::Image& image, int x, int y) {
    const std::uint8_t* p = &image.rgba[4 * (static_cast<std::size_t>(y) * image.width + x)];
    return int(p[0]) + p[1] + p[2];
  };
  // The left part (x <= 120 mm: fixed, on the left 40 % of the picture) is bit-identical.
  int first_changed = a.width;
  for (int y = 0; y < a.height; ++y) {
    for (int x = 0; x < a.width; ++x) {
      if (pixel(a, x, y) != pixel(b, x, y)) first_changed = std::min(first_changed, x);
    }
  }
  EXPECT_GT(first_changed, 0.4 * a.width);
  // Through the slot the background shows: a run of at least three columns, each with 25 or
  // more pixels darker than the whole engine's by over 25 levels (of 3 x 255).
  int run = 0, longest = 0;
  for (int x = 0; x < a.width; ++x) {
    int darker = 0;
    for (int y = 0; y < a.height; ++y) darker += pixel(a, x, y) - pixel(b, x, y) > 75;
    run = darker >= 25 ? run + 1 : 0;
    longest = std::max(longest, run);
  }
  EXPECT_GE(longest, 3);
}

}  // namespace
}  // namespace hapvox
