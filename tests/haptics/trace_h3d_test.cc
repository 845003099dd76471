// H3D DeviceLog text logs as traces (haptics/trace_h3d.h), orientation columns in CSV traces,
// and the orientation's resampling.
#include "haptics/trace_h3d.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <string>

#include "engine/errors.h"
#include "test_data.h"

namespace hapvox::haptics {
namespace {

using ::hapvox::testing::input_error_of;
using ::hapvox::testing::scratch_dir;

// As HAPI::DeviceLog writes with logData "ALL" minus the RAW_ fields: fixed, 5 decimals,
// metres, axis-angle orientations.
const char kLog[] =
    "TIME POSITION ORIENTATION VELOCITY BUTTONS FORCE TORQUE\n"
    "0.00000 0.01000 0.02000 0.03000 0.00000 0.00000 1.00000 0.00000 0.00000 0.00000 0.00000 "
    "0 0.00000 0.00000 0.00000 0.00000 0.00000 0.00000\n"
    "0.00100 0.01100 0.02000 0.03000 0.00000 0.00000 1.00000 1.57080 0.10000 0.00000 0.00000 "
    "1 0.00000 0.00000 0.50000 0.00000 0.00000 0.00000\n"
    "0.00200 0.01200 0.02050 0.02900 2.00000 0.00000 0.00000 3.14159 0.10000 0.00000 0.00000 "
    "1 0.00000 0.00000 0.50000 0.00000 0.00000 0.00000\n";

TEST(H3dDeviceLog, ReadsTimePositionInMillimetresAndOrientation) {
  const Trace trace = parse_h3d_device_log(kLog, "log.txt");
  ASSERT_EQ(trace.time_s.size(), 3u);
  EXPECT_EQ(trace.time_s[1], 0.001);
  EXPECT_NEAR((trace.position_mm[0] - Vec3d(10, 20, 30)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((trace.position_mm[2] - Vec3d(12, 20.5, 29)).norm(), 0.0, 1e-12);
  ASSERT_EQ(trace.orientation.size(), 3u);
  // 1.5708 rad about z: a quarter turn takes x to y.
  EXPECT_NEAR((trace.orientation[1] * Vec3d::UnitX() - Vec3d::UnitY()).norm(), 0.0, 1e-5);
  // pi about x (an axis of any length): y to -y.
  EXPECT_NEAR((trace.orientation[2] * Vec3d::UnitY() + Vec3d::UnitY()).norm(), 0.0, 1e-5);
  EXPECT_NEAR(trace.orientation[0].angularDistance(Eigen::Quaterniond::Identity()), 0.0, 1e-15);
}

TEST(H3dDeviceLog, TakesTheRawPoseWhenTheLogHasNoTrackerPose) {
  const Trace trace = parse_h3d_device_log(
      "TIME RAW_POSITION RAW_ORIENTATION\n0 0.1 0 0 0 0 1 0\n0.5 0.2 0 0 0 0 1 0.5\n", "raw.txt");
  EXPECT_NEAR((trace.position_mm[1] - Vec3d(200, 0, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(trace.orientation[1].angularDistance(Eigen::Quaterniond::Identity()), 0.5, 1e-12);
  // Without an orientation field the trace has none.
  EXPECT_TRUE(
      parse_h3d_device_log("TIME POSITION\n0 0 0 0\n1 0 0 0.001\n", "p.txt").orientation.empty());
}

TEST(H3dDeviceLog, EachBadLogGivesItsOneLine) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"TIME POSITION\n0 0 0 0\n0.1 0 0\n",
       "log.txt: line 3: expected 4 numbers for the header's fields, found 3"},
      {"TIME POSITION\n0 0 0 0\n0.1 0 0 x\n", "log.txt: line 3: not a number: 'x'"},
      {"TIME POSITION\n0 0 0 0\n0 0 0 1\n",
       "log.txt: line 3: time 0 does not increase (previous 0)"},
      {"TIME VELOCITY\n0 0 0 0\n", "log.txt: line 1: the log holds no POSITION or RAW_POSITION"},
      {"TIME POSITION ORIENTATION\n0 0 0 0 0 0 0 1\n",
       "log.txt: line 2: orientation turns by 1 rad about a zero axis"},
      {"TIME POSITION\n0 0 0 nan\n0.1 0 0 0\n",
       "log.txt: line 2: field 'POSITION z': NaN or infinite value"},
      {"TIME POSITION\n0 0 0 0\n", "log.txt: need at least 2 samples, found 1"},
      {"TIME POSITION ANGLE\n",
       "log.txt: line 1: not an H3D DeviceLog header (DeviceLog field "
       "names with TIME among them: TIME, POSITION, ORIENTATION, "
       "VELOCITY, FORCE, TORQUE, BUTTONS, RAW_POSITION, "
       "RAW_ORIENTATION, RAW_VELOCITY, RAW_FORCE, RAW_TORQUE, TIMESTAMP)"},
      {std::string("TIME POSITION") + '\0' + "\x01\x02",
       "log.txt: a binary H3D DeviceLog (logBinary TRUE) is not read: log with logBinary FALSE "
       "for a text log"},
  };
  for (const auto& [text, message] : cases) {
    EXPECT_EQ(input_error_of([&] { parse_h3d_device_log(text, "log.txt"); }), message) << text;
  }
}

TEST(H3dDeviceLog, ReadTraceTellsADeviceLogFromACsvByItsHeader) {
  const std::string dir = scratch_dir();
  std::ofstream(dir + "/log.txt") << "\n" << kLog;
  std::ofstream(dir + "/trace.csv") << "t,x,y,z\n0,0,0,0\n1,1,0,0\n";
  // A CSV whose only column is named TIME is a CSV: DeviceLog headers have no commas.
  std::ofstream(dir + "/time.csv") << "TIME,x,y,z\n0,0,0,0\n1,1,0,0\n";
  EXPECT_TRUE(is_h3d_device_log(dir + "/log.txt"));
  EXPECT_FALSE(is_h3d_device_log(dir + "/trace.csv"));
  EXPECT_FALSE(is_h3d_device_log(dir + "/time.csv"));
  EXPECT_FALSE(is_h3d_device_log(dir + "/missing.txt"));
  const Trace log = read_trace(dir + "/log.txt");
  EXPECT_EQ(log.orientation.size(), 3u);
  EXPECT_NEAR(log.position_mm[1].x(), 11.0, 1e-12);
  TraceColumns columns;
  columns.time = "TIME";
  EXPECT_EQ(read_trace(dir + "/time.csv", columns).time_s.size(), 2u);
}

TEST(TraceOrientation, CsvColumnsAreNormalisedAndAZeroQuaternionIsRefused) {
  TraceColumns columns;
  columns.orientation = {"qw", "qx", "qy", "qz"};
  const Trace trace =
      parse_csv_trace("t,x,y,z,qw,qx,qy,qz\n0,0,0,0,2,0,0,0\n1,1,0,0,0,0,0,3\n", "q.csv", columns);
  ASSERT_EQ(trace.orientation.size(), 2u);
  EXPECT_EQ(trace.orientation[0].coeffs(), Eigen::Quaterniond::Identity().coeffs());
  EXPECT_EQ(trace.orientation[1].coeffs(), Eigen::Quaterniond(0, 0, 0, 1).coeffs());
  EXPECT_EQ(input_error_of([&] {
              parse_csv_trace("t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,1,0,0,0,0,0,0\n", "q.csv",
                              columns);
            }),
            "q.csv: line 3: orientation (0, 0, 0, 0) is not a rotation (zero length)");
  EXPECT_EQ(
      input_error_of([&] { parse_csv_trace("t,x,y,z\n0,0,0,0\n1,1,0,0\n", "q.csv", columns); }),
      "q.csv: missing column 'qw' (columns are: t, x, y, z)");
}

TEST(TraceOrientation, ResamplingTurnsAlongTheShorterArc) {
  Trace trace;
  trace.time_s = {0.0, 1.0};
  trace.position_mm = {Vec3d::Zero(), Vec3d(10, 0, 0)};
  // A quarter turn about z, written with the opposite sign: the same rotation.
  trace.orientation = {
      Eigen::Quaterniond::Identity(),
      Eigen::Quaterniond(-std::cos(std::numbers::pi / 4), 0, 0, -std::sin(std::numbers::pi / 4))};
  ResampleOptions options;
  options.rate_hz = 4.0;
  options.max_gap_s = 2.0;  // one step of 1 s, not a gap
  const ResampledTrace r = resample(trace, options);
  ASSERT_EQ(r.orientation.size(), 5u);
  for (std::size_t k = 0; k < 5; ++k) {
    // At tick k the turn is k/4 of 90 degrees, never the long way round.
    EXPECT_NEAR(r.orientation[k].angularDistance(Eigen::Quaterniond::Identity()),
                std::numbers::pi / 2 * static_cast<double>(k) / 4.0, 1e-12)
        << k;
  }
  EXPECT_NEAR((r.orientation[2] * Vec3d::UnitX() -
               Vec3d(std::cos(std::numbers::pi / 4), std::sin(std::numbers::pi / 4), 0))
                  .norm(),
              0.0, 1e-12);
}

}  // namespace
}  // namespace hapvox::haptics
