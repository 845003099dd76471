// `hapvox replay --model fem --render-dir`: the paper's Fig. 6 on the bundled engine CT. The
// engine's left part is fixed (data/engine_grab.toml), its right end grabbed and lifted 12 mm
// (traces/engine_grab.csv); seen from the front, the frames show the right end move while
// the fixed part's pixels stay as they were.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "haptics/session.h"
#include "render/camera.h"
#include "render/image.h"
#include "test_data.h"

namespace hapvox {
namespace {

using testing::run_hapvox;
using testing::scratch_dir;
using testing::source_path;

std::string frame_name(int frame) {
  char name[32];
  std::snprintf(name, sizeof name, "frame_%04d.png", frame);
  return name;
}

// The pixel box (x0, y0, x1, y1) that the world box [lo, hi] projects into.
Eigen::Vector4i pixel_box(const render::OrbitCamera& camera, int width, int height,
                          const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  const Eigen::Matrix4d mvp =
      camera.projection(static_cast<double>(width) / height, 1.0, 1e5) * camera.view();
  Eigen::Vector4i box(width, height, 0, 0);
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d p((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(),
                            (k & 4) ? hi.z() : lo.z());
    const Eigen::Vector4d clip = mvp * p.homogeneous();
    const double x = (clip.x() / clip.w() * 0.5 + 0.5) * width;
    const double y = (0.5 - clip.y() / clip.w() * 0.5) * height;
    box[0] = std::min(box[0], static_cast<int>(std::floor(x)));
    box[1] = std::min(box[1], static_cast<int>(std::floor(y)));
    box[2] = std::max(box[2], static_cast<int>(std::ceil(x)));
    box[3] = std::max(box[3], static_cast<int>(std::ceil(y)));
  }
  return box;
}

TEST(ReplayFemRender, AGrabbedEndMovesInTheFramesWhileTheFixedPartsPixelsDoNot) {
  const std::string dir = scratch_dir();
  const std::string volume = source_path("data/engine_256x256x128_uint8.nrrd");
  const auto r = run_hapvox(
      "replay " + source_path("traces/engine_grab.csv") + " --volume " + volume +
      " --model fem --materials " + source_path("data/engine_grab.toml") +
      " --interaction grab --tool-diameter-mm 24 --coupling-n-per-mm 1000 --max-force-n 10000"
      " --ramp-in-s 0 --spacing-mm 16 --boundary-levels 0 -o " +
      dir + "/s.h5 --render-dir " + dir +
      "/frames --render-every-ticks 500 --render-size 160x120 --render-azimuth-deg -90"
      " --render-elevation-deg 0 --render-shadows");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("render           2 frames to"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("a frame, shadows\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("proxy render     2 resamples"), std::string::npos) << r.out;
  const render::Image before = render::read_png(dir + "/frames/frame_0000.png");
  const render::Image after = render::read_png(dir + "/frames/frame_0001.png");
  // The recorder's camera: framing the volume from the front (looking along +y, x to the
  // right, z up).
  const render::OrbitCamera camera = render::OrbitCamera::framing(
      Eigen::Vector3d::Constant(-0.5), Eigen::Vector3d(255.5, 255.5, 127.5), -90.0, 0.0);
  // The engine spans x 62..201 mm, y 25..221, z 0..107; x <= 120 is fixed.
  const Eigen::Vector4i fixed = pixel_box(camera, 160, 120, {62, 25, 0}, {100, 221, 107});
  const Eigen::Vector4i grabbed = pixel_box(camera, 160, 120, {170, 25, 0}, {201, 221, 119});
  ASSERT_LT(fixed[2], grabbed[0]);  // the two boxes apart on the screen
  const double fixed_change =
      render::mean_abs_difference(before, after, fixed[0], fixed[1], fixed[2], fixed[3]);
  const double grabbed_change =
      render::mean_abs_difference(before, after, grabbed[0], grabbed[1], grabbed[2], grabbed[3]);
  std::printf("mean |difference|: fixed part %.4f, grabbed part %.2f (of 255)\n", fixed_change,
              grabbed_change);
  EXPECT_EQ(fixed_change, 0.0);
  EXPECT_GT(grabbed_change, 5.0);
  // The session says what was drawn.
  const haptics::SessionInfo info = haptics::read_session_info(dir + "/s.h5");
  const auto frames =
      std::find_if(info.attributes.begin(), info.attributes.end(),
                   [](const auto& a) { return a.first == "summary_render_frames"; });
  ASSERT_NE(frames, info.attributes.end());
  EXPECT_EQ(frames->second, "2");
  const auto shadows = std::find_if(info.attributes.begin(), info.attributes.end(),
                                    [](const auto& a) { return a.first == "render_shadows"; });
  ASSERT_NE(shadows, info.attributes.end());
  EXPECT_EQ(shadows->second, "1");
}

// Fig. 5's grab (41.33,85.67,41.33 -> 46.99,85.67,46.99 mm) made in the first 0.3 s, then
// held until `end_s`.
void write_grab_and_hold(const std::string& path, double end_s) {
  std::ofstream trace(path);
  trace << "t,x,y,z\n";
  for (int k = 0; k <= static_cast<int>(std::lround(end_s * 1000.0)); ++k) {
    const double xz_mm = 41.33 + std::min(k / 300.0, 1.0) * (46.99 - 41.33);
    trace << k * 1e-3 << ',' << xz_mm << ",85.67," << xz_mm << '\n';
  }
}

int count_frames(const std::string& dir) {
  int frames = 0;
  while (std::filesystem::exists(dir + "/" + frame_name(frames))) ++frames;
  return frames;
}

// Realtime: the render thread resamples what the FEM thread published (also run under TSan).
// Its last frame, drawn when the run ends, shows the held grab as the lockstep replay draws
// it. The grab is held for 2.7 s, so however slowly a sanitizer build on a busy machine steps
// the FEM and draws (ThreadSanitizer beside two busy cores: 40-140 ms a FEM step, 0.5-2 s a
// frame), the FEM has stepped at the held position before the run ends. Comparing the
// realtime run's own first and last frames is no test there: its first frame may come after
// the grab (it once did), or the last before the grab was made (a trace moving all along
// once left a TSan run's last frame at 0.2 s of the move).
TEST(ReplayFemRender, RealtimeFramesShowTheFemThreadsDisplacements) {
  const std::string dir = scratch_dir();
  write_grab_and_hold(dir + "/grab_and_hold.csv", 3.0);
  write_grab_and_hold(dir + "/grab_short_hold.csv", 0.4);
  // 32^3 voxels of 4 mm (the same 128 mm box): each resample of the deformed volume costs a
  // quarter of 64^3's.
  const std::string model =
      " --volume four-spheres:dims=32,voxel_mm=4 --model fem --materials " +
      source_path("data/four_spheres.toml") +
      " --interaction grab --tool-diameter-mm 30 --spacing-mm 16 --boundary-levels 0"
      " --coupling-n-per-mm 1000 --max-force-n 10000 --ramp-in-s 0 --render-fps 20"
      " --render-size 64";
  const auto lockstep = run_hapvox("replay " + dir + "/grab_short_hold.csv" + model + " -o " + dir +
                                   "/lockstep.h5 --render-dir " + dir + "/lockstep");
  ASSERT_EQ(lockstep.exit_code, 0) << lockstep.out << lockstep.err;
  const auto r = run_hapvox("replay " + dir + "/grab_and_hold.csv" + model +
                            " --realtime --no-rt-priority --no-mlock -o " + dir +
                            "/s.h5 --render-dir " + dir + "/frames");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const int lockstep_frames = count_frames(dir + "/lockstep");
  ASSERT_GE(lockstep_frames, 2) << lockstep.out;
  const int frames = count_frames(dir + "/frames");
  ASSERT_GE(frames, 1) << r.out;
  const render::Image rest = render::read_png(dir + "/lockstep/" + frame_name(0));
  const render::Image held = render::read_png(dir + "/lockstep/" + frame_name(lockstep_frames - 1));
  const render::Image last = render::read_png(dir + "/frames/" + frame_name(frames - 1));
  // The grab shows (29.3 dB from the rest frame in a release build), as in the lockstep run
  // (bit-identical in release: the same static solve at the same held position).
  EXPECT_LT(render::psnr_db(rest, last), 35.0) << r.out;
  EXPECT_GT(render::psnr_db(held, last), 45.0) << r.out;
  EXPECT_EQ(r.out.find("proxy render     0 resamples"), std::string::npos) << r.out;
}

TEST(ReplayFemRender, AnUnknownGradientTransformIsOneLineAndNoOutput) {
  const std::string dir = scratch_dir();
  const auto r = run_hapvox("replay " + source_path("traces/fig5_grab.csv") +
                            " --volume four-spheres:dims=32 --model fem --materials " +
                            source_path("data/four_spheres.toml") + " -o " + dir +
                            "/s.h5 --render-dir " + dir + "/frames --render-gradient polar");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err,
            "hapvox: error: --render-gradient: unknown gradient transform 'polar' (rotation or "
            "inverse-transpose)\n");
  EXPECT_FALSE(std::filesystem::exists(dir + "/s.h5"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/frames"));
}

}  // namespace
}  // namespace hapvox
