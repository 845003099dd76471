// hapvox sculpt under Xvfb, driven by a script: the window carves a groove in the clay
// block, its screenshots show it, and the trace it wrote replays the session in lockstep
// bit for bit (the forces on every tick sent with the same ramp factor, the relaxation tick
// by tick, the sculpted volume byte for byte). Bad input is one line and makes no file.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "haptics/session.h"
#include "render/image.h"
#include "test_data.h"

namespace hapvox {
namespace {

using testing::run_hapvox;
using testing::run_hapvox_env;
using testing::scratch_dir;

// A display for the window on a machine without one (Debian's xvfb).
const char kXvfb[] = "xvfb-run -a -s '-screen 0 1024x768x24'";

std::string attribute(const haptics::SessionInfo& info, const std::string& name) {
  for (const auto& [key, value] : info.attributes) {
    if (key == name) return value;
  }
  return "";
}

TEST(SculptCli, ARealtimeWindowCarvesAGrooveThatItsTraceReplaysBitForBit) {
  const std::string dir = scratch_dir();
  // The bundled groove (traces/clay_groove.script), with a screenshot before the stroke.
  std::ofstream(dir + "/groove.script")
      << "0.3 screenshot " << dir << "/before.png\n"
      << testing::read_file(testing::source_path("traces/clay_groove.script"));
  const testing::CommandResult sculpt = run_hapvox_env(
      kXvfb, "sculpt block --script " + dir + "/groove.script -o " + dir + "/s.h5 --screenshot " +
                 dir + "/after.png --sculpt-out " + dir + "/live -q --no-mlock");
  ASSERT_EQ(sculpt.exit_code, 0) << sculpt.err << sculpt.out;
  EXPECT_NE(sculpt.out.find("sculpted with mouse on block -> " + dir + "/s.h5"), std::string::npos)
      << sculpt.out;
  EXPECT_NE(sculpt.out.find("1 strokes (0 picked nothing)"), std::string::npos) << sculpt.out;

  // The groove: clay was deleted and relaxed, its mass kept exactly.
  const haptics::SessionInfo info = haptics::read_session_info(dir + "/s.h5");
  EXPECT_TRUE(info.complete);
  EXPECT_EQ(attribute(info, "device"), "mouse");
  EXPECT_EQ(attribute(info, "relax_schedule"), "lockstep, paced by the clock");
  EXPECT_EQ(attribute(info, "summary_initial_mass_units"),
            attribute(info, "summary_final_mass_units"));
  EXPECT_GT(std::stoll(attribute(info, "summary_plastic_events")), 100);
  // ... and the screenshots show it: where the tool ploughed, the window changed.
  const render::Image before = render::read_png(dir + "/before.png");
  const render::Image after = render::read_png(dir + "/after.png");
  ASSERT_EQ(before.width, 800);
  ASSERT_EQ(before.height, 600);
  ASSERT_EQ(after.width, 800);
  EXPECT_GT(render::mean_abs_difference(before, after, 300, 250, 550, 450), 4.0);
  // Far from the stroke (the bottom corners) nothing changed.
  EXPECT_LT(render::mean_abs_difference(before, after, 0, 560, 80, 600), 0.5);

  // The trace it wrote, replayed in lockstep.
  const testing::CommandResult again =
      run_hapvox("replay " + dir + "/s.csv --volume block --plastic -q -o " + dir +
                 "/again.h5 --sculpt-out " + dir + "/again");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  for (const char* column : {"/relax/total_mass_units", "/relax/deleted_voxels",
                             "/relax/relaxed_voxels", "/plastic/event", "/tool_position_mm"}) {
    EXPECT_EQ(haptics::read_session_column(dir + "/s.h5", column),
              haptics::read_session_column(dir + "/again.h5", column))
        << column;
  }
  const std::vector<double> live_force = haptics::read_session_column(dir + "/s.h5", "/force_n");
  const std::vector<double> again_force =
      haptics::read_session_column(dir + "/again.h5", "/force_n");
  const std::vector<double> live_scale =
      haptics::read_session_column(dir + "/s.h5", "/force_scale");
  const std::vector<double> again_scale =
      haptics::read_session_column(dir + "/again.h5", "/force_scale");
  ASSERT_EQ(live_force.size(), again_force.size());
  std::size_t same_ramp = 0;
  for (std::size_t k = 0; k < live_scale.size(); ++k) {
    if (live_scale[k] != again_scale[k]) continue;
    ++same_ramp;
    for (int a = 0; a < 3; ++a) ASSERT_EQ(live_force[3 * k + a], again_force[3 * k + a]) << k;
  }
  EXPECT_GE(same_ramp, 500u);  // watchdog trips on a loaded machine ramp ~200 ticks each
  EXPECT_EQ(testing::read_file(dir + "/live.nrrd"), testing::read_file(dir + "/again.nrrd"));
}

TEST(SculptCli, BadInputIsOneLineAndMakesNoFile) {
  const std::string dir = scratch_dir();
  const std::string out = " -o " + dir + "/s.h5";
  // The message, or with `prefix` its start (then one line).
  auto expect_error = [&](const std::string& environment, const std::string& args,
                          const std::string& message, bool prefix = false) {
    const testing::CommandResult r = run_hapvox_env(environment, "sculpt block" + args + out);
    EXPECT_EQ(r.exit_code, 2) << args;
    if (prefix) {
      EXPECT_EQ(r.err.rfind("hapvox: error: " + message, 0), 0u) << r.err;
      EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
    } else {
      EXPECT_EQ(r.err, "hapvox: error: " + message + "\n") << args;
    }
    EXPECT_FALSE(std::filesystem::exists(dir + "/s.h5")) << args;
    EXPECT_FALSE(std::filesystem::exists(dir + "/s.csv")) << args;
  };
  expect_error("env -u DISPLAY", "",
               "sculpt: no display (DISPLAY is not set): run it on a desktop, or headless under "
               "xvfb-run");
  expect_error("DISPLAY=:97531", "", "sculpt: cannot open the display ':97531': ", true);
  std::ofstream(dir + "/bad.script") << "0 press\n0.5 shake\n";
  expect_error(kXvfb, " --script " + dir + "/bad.script",
               dir +
                   "/bad.script:2: unknown event 'shake' (move, press, release, wheel, key, "
                   "screenshot, quit)");
  expect_error(kXvfb, " --screenshot " + dir + "/shot.jpg", "--screenshot: must name a .png file");
  expect_error(kXvfb, " --elastic --plastic", "--elastic: cannot go with --plastic");
  expect_error(kXvfb, " --model fem",
               "--model: sculpt runs the voxel model (the proxy mesh is refined along a trace, "
               "which a live session does not have ahead)");
}

}  // namespace
}  // namespace hapvox
