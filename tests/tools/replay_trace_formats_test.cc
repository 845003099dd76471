// `hapvox replay` with traces from other tools: an H3D DeviceLog text log (seconds, metres,
// axis-angle orientation) and a CSV with orientation columns; the stylus orientation is kept
// in the session for 6-DoF use.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include "haptics/session.h"
#include "test_data.h"

namespace hapvox {
namespace {

using testing::run_hapvox;
using testing::scratch_dir;

std::string attribute(const std::string& session, const std::string& name) {
  for (const auto& [key, value] : haptics::read_session_info(session).attributes) {
    if (key == name) return value;
  }
  return "";
}

TEST(ReplayTraceFormats, AnH3dDeviceLogReplaysInMillimetresWithItsOrientation) {
  const std::string dir = scratch_dir();
  // 0.2 s at 1 kHz: the stylus moves 10 mm along x (0.01 m) while turning a quarter turn
  // about z, as HAPI::DeviceLog writes it (fixed, 5 decimals).
  std::ofstream log(dir + "/device.log");
  log << "TIME POSITION ORIENTATION BUTTONS\n";
  char row[200];
  for (int k = 0; k <= 200; ++k) {
    const double s = k / 200.0;
    std::snprintf(row, sizeof row, "%.5f %.5f %.5f %.5f %.5f %.5f %.5f %.5f 0\n", k / 1000.0,
                  0.01 + 0.01 * s, 0.02, 0.06, 0.0, 0.0, 1.0, s * std::numbers::pi / 2);
    log << row;
  }
  log.close();
  const std::string session = dir + "/s.h5";
  const auto r =
      run_hapvox("replay " + dir + "/device.log --volume block:dims=48 -q -o " + session);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(attribute(session, "trace_format"), "h3d-devicelog");
  const auto position = haptics::read_session_column(session, "/device_position_mm");
  ASSERT_EQ(position.size(), 201u * 3);
  EXPECT_NEAR(position[0], 10.0, 1e-9);
  EXPECT_NEAR(position[3 * 200], 20.0, 1e-9);
  EXPECT_NEAR(position[3 * 200 + 2], 60.0, 1e-9);
  const auto turn = haptics::read_session_column(session, "/device_orientation");
  ASSERT_EQ(turn.size(), 201u * 4);
  // The last tick: a quarter turn about z (w = cos 45, z = sin 45), to the log's 5 decimals.
  EXPECT_NEAR(turn[4 * 200], std::cos(std::numbers::pi / 4), 1e-5);
  EXPECT_NEAR(turn[4 * 200 + 3], std::sin(std::numbers::pi / 4), 1e-5);
  EXPECT_NEAR(turn[0], 1.0, 1e-12);
}

TEST(ReplayTraceFormats, CsvOrientationColumnsAreKeptPerTick) {
  const std::string dir = scratch_dir();
  std::ofstream(dir + "/t.csv") << "t,x,y,z,w,i,j,k\n0,10,20,60,1,0,0,0\n0.1,20,20,60,0,0,0,1\n";
  const std::string session = dir + "/s.h5";
  // Two samples 0.1 s apart: one step (--max-gap-s 1), not a gap the tool holds across.
  const auto r = run_hapvox("replay " + dir +
                            "/t.csv --volume block:dims=48 --max-gap-s 1 --orientation-cols "
                            "w,i,j,k -q -o " +
                            session);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto turn = haptics::read_session_column(session, "/device_orientation");
  ASSERT_EQ(turn.size(), 101u * 4);
  // Halfway (tick 50): half of a half turn about z.
  EXPECT_NEAR(turn[4 * 50], std::cos(std::numbers::pi / 4), 1e-12);
  EXPECT_NEAR(turn[4 * 50 + 3], std::sin(std::numbers::pi / 4), 1e-12);
  // Without the flag there is no orientation dataset.
  ASSERT_EQ(run_hapvox("replay " + dir + "/t.csv --volume block:dims=48 -q -o " + dir + "/p.h5")
                .exit_code,
            0);
  EXPECT_EQ(attribute(dir + "/p.h5", "trace_format"), "");
  const auto bad = run_hapvox("replay " + dir +
                              "/t.csv --volume block:dims=48 --orientation-cols "
                              "w,i,j -q -o " +
                              dir + "/bad.h5");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_EQ(bad.err,
            "hapvox: error: --orientation-cols: expected four column names W,X,Y,Z, got 'w,i,j'\n");
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.h5"));
}

}  // namespace
}  // namespace hapvox
