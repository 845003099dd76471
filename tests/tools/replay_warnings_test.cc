// The warnings of a replay summary (tools/replay_warnings.cc): a trace that keeps the tool
// wholly outside the volume, a tool that starts inside the material; none on the bundled
// cases. Lockstep and realtime replays share them.

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "test_data.h"

namespace hapvox {
namespace {

using testing::scratch_dir;
using testing::source_path;
using Result = testing::CommandResult;

// A two-sample trace (50 ms) from `from` to `to`, "X,Y,Z" in mm.
std::string write_trace(const std::string& path, const std::string& from, const std::string& to) {
  std::ofstream(path) << "t,x,y,z\n0," << from << "\n0.05," << to << "\n";
  return path;
}

// block:dims=64 is the box (-0.5 .. 63.5 mm)^3 with clay below z = 31.5 mm; the tool is the
// default 8 mm sphere.
constexpr const char* kBox = "the volume's box is (-0.5, -0.5, -0.5) .. (63.5, 63.5, 63.5)";
constexpr const char* kInsideTail =
    " mm: with no free position before that contact, its force starts from zero there rather "
    "than at the surface\n";

std::string outside_line(const std::string& trace, const std::string& lo, const std::string& hi) {
  return "hapvox: warning: " + trace + ": the tool never reaches the volume: its centre stays in " +
         lo + " .. " + hi + " mm, " + kBox +
         " mm (check --offset-mm, --scale, --rotate-deg or --fit)\n";
}

void expect_warnings(const std::string& mode) {
  const std::string dir = scratch_dir();
  const std::string replay = "replay --volume block:dims=64 -q " + mode + " -o " + dir + "/s.h5 ";
  // Wholly outside: moved 200 mm along x.
  const std::string away = write_trace(dir + "/away.csv", "32,32,50", "32,32,46");
  Result r = testing::run_hapvox(replay + away + " --offset-mm 200,0,0");
  EXPECT_EQ(r.exit_code, 0) << r.err;  // a warning, not an error: the session is written
  EXPECT_EQ(r.err, outside_line(away, "(232, 32, 46)", "(232, 32, 50)"));
  EXPECT_NE(r.out.find(" 0 contact onsets"), std::string::npos) << r.out;
  // The sphere, not its centre: 3.9 mm above the box's top face it meets the box, 4.1 mm not.
  const std::string near = write_trace(dir + "/near.csv", "32,32,67.4", "32,32,67.4");
  r = testing::run_hapvox(replay + near);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  const std::string far = write_trace(dir + "/far.csv", "32,32,67.6", "32,32,67.6");
  r = testing::run_hapvox(replay + far);
  EXPECT_EQ(r.err, outside_line(far, "(32, 32, 67.6)", "(32, 32, 67.6)"));
  // Starts inside the clay.
  const std::string inside = write_trace(dir + "/inside.csv", "32,32,20", "32,32,19");
  r = testing::run_hapvox(replay + inside);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "hapvox: warning: " + inside + ": the tool starts inside the material at " +
                       "(32, 32, 20)" + kInsideTail);
  // Starting outside and pressing in is the normal case.
  const std::string press = write_trace(dir + "/press.csv", "32,32,40", "32,32,33");
  r = testing::run_hapvox(replay + press);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_NE(r.out.find("1 contact onsets"), std::string::npos) << r.out;
}

TEST(ReplayWarnings, LockstepWarnsOfATraceOutsideTheVolumeAndAToolStartingInside) {
  expect_warnings("");
}

// The name holds "Realtime": ctest runs it alone (a wall-clock loop).
TEST(ReplayWarnings, RealtimeWarnsOfATraceOutsideTheVolumeAndAToolStartingInside) {
  expect_warnings("--realtime --no-mlock");
}

TEST(ReplayWarnings, TheBundledTracesGetNone) {
  const std::string dir = scratch_dir();
  const Result engine = testing::run_hapvox(
      "replay " + source_path("traces/engine_press.csv") + " --volume " +
      source_path("data/engine_256x256x128_uint8.nrrd") + " -q -o " + dir + "/engine.h5");
  EXPECT_EQ(engine.exit_code, 0) << engine.err;
  EXPECT_EQ(engine.err, "");
  const Result clay = testing::run_hapvox("replay " + source_path("traces/clay_stroke.csv") +
                                          " --volume block --plastic -q -o " + dir + "/clay.h5");
  EXPECT_EQ(clay.exit_code, 0) << clay.err;
  EXPECT_EQ(clay.err, "");
}

TEST(ReplayWarnings, TheBundledRealtimeCaseGetsNone) {
  const std::string dir = scratch_dir();
  const Result r = testing::run_hapvox("replay " + source_path("traces/clay_stroke.csv") +
                                       " --volume block --plastic --realtime --no-mlock -q -o " +
                                       dir + "/clay.h5");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace hapvox
