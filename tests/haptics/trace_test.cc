#include "haptics/trace.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "test_data.h"

namespace hapvox::haptics {
namespace {

using ::hapvox::testing::input_error_of;
using ::testing::HasSubstr;

// scratch_dir() empties the directory, so call this once per test.
std::string write_text(const std::string& name, const std::string& text) {
  const std::string path = hapvox::testing::scratch_dir() + "/" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// A small trace with awkward values, so exact round trips mean something.
Trace awkward_trace() {
  Trace trace;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> dist(-1e3, 1e3);
  double t = 0.1;
  for (int i = 0; i < 50; ++i) {
    trace.time_s.push_back(t);
    t += 1.0 / 3.0 + 1e-7 * i;
    trace.position_mm.emplace_back(dist(rng), dist(rng) * 1e-9, dist(rng) * 1e12);
  }
  trace.position_mm[3] = Vec3d(-0.0, 5e-324, 1.7976931348623157e308);
  return trace;
}

void expect_bit_equal(const Trace& a, const Trace& b) {
  ASSERT_EQ(a.time_s.size(), b.time_s.size());
  ASSERT_EQ(a.position_mm.size(), b.position_mm.size());
  for (std::size_t i = 0; i < a.time_s.size(); ++i) {
    EXPECT_EQ(std::memcmp(&a.time_s[i], &b.time_s[i], sizeof(double)), 0) << i;
    EXPECT_EQ(std::memcmp(a.position_mm[i].data(), b.position_mm[i].data(), 3 * sizeof(double)), 0)
        << i;
  }
}

// --- CSV ----------------------------------------------------------------------------------

TEST(TraceCsvTest, RoundTripIsExact) {
  const std::string path = hapvox::testing::scratch_dir() + "/trace.csv";
  const Trace trace = awkward_trace();
  write_csv_trace(trace, path);
  EXPECT_FALSE(std::filesystem::exists(path + ".partial"));
  expect_bit_equal(read_csv_trace(path), trace);
  expect_bit_equal(read_trace(path), trace);
}

// A trace with an orientation writes it as qw,qx,qy,qz, which --orientation-cols reads back:
// the same unit quaternions (normalised again on reading: to the last bit or two).
TEST(TraceCsvTest, AnOrientationRoundTripsThroughItsQuaternionColumns) {
  const std::string path = hapvox::testing::scratch_dir() + "/turning.csv";
  Trace trace = awkward_trace();
  for (std::size_t i = 0; i < trace.time_s.size(); ++i) {
    const double half_angle = 0.05 * static_cast<double>(i);
    trace.orientation.push_back(Eigen::Quaterniond(std::cos(half_angle), 0.6 * std::sin(half_angle),
                                                   0.0, 0.8 * std::sin(half_angle)));
  }
  write_csv_trace(trace, path);
  TraceColumns columns;
  columns.orientation = {"qw", "qx", "qy", "qz"};
  const Trace back = read_trace(path, columns);
  expect_bit_equal(back, trace);
  ASSERT_EQ(back.orientation.size(), trace.orientation.size());
  for (std::size_t i = 0; i < trace.orientation.size(); ++i) {
    EXPECT_NEAR(back.orientation[i].w(), trace.orientation[i].w(), 1e-15) << i;
    EXPECT_NEAR(back.orientation[i].x(), trace.orientation[i].x(), 1e-15) << i;
    EXPECT_NEAR(back.orientation[i].y(), trace.orientation[i].y(), 1e-15) << i;
    EXPECT_NEAR(back.orientation[i].z(), trace.orientation[i].z(), 1e-15) << i;
  }
  // Without one the file stays t,x,y,z.
  trace.orientation.clear();
  write_csv_trace(trace, path);
  std::ifstream in(path);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "t,x,y,z");
}

TEST(TraceCsvTest, ExtraColumnsIgnoredAndOrderFree) {
  const std::string path = write_text("t.csv",
                                      "force, z ,\"y\",x,t,label\n"
                                      "# a comment\n"
                                      "\n"
                                      "9,3,2,1,0,foo\n"
                                      "9,6,5,4,0.5,bar\n");
  const Trace trace = read_csv_trace(path);
  ASSERT_EQ(trace.time_s.size(), 2u);
  EXPECT_EQ(trace.time_s[1], 0.5);
  EXPECT_EQ(trace.position_mm[0], Vec3d(1, 2, 3));
  EXPECT_EQ(trace.position_mm[1], Vec3d(4, 5, 6));
}

TEST(TraceCsvTest, CustomColumnsAndUnits) {
  const std::string path = write_text("t.csv",
                                      "time_ms,px,py,pz\n"
                                      "0,0.001,0.002,-0.003\n"
                                      "250,0.5,1,+2\n");
  TraceColumns columns;
  columns.time = "time_ms";
  columns.position = {"px", "py", "pz"};
  columns.seconds_per_time_unit = 1e-3;
  columns.mm_per_position_unit = 1000.0;
  const Trace trace = read_csv_trace(path, columns);
  ASSERT_EQ(trace.time_s.size(), 2u);
  EXPECT_DOUBLE_EQ(trace.time_s[1], 0.25);
  EXPECT_TRUE(trace.position_mm[0].isApprox(Vec3d(1, 2, -3)));
  EXPECT_TRUE(trace.position_mm[1].isApprox(Vec3d(500, 1000, 2000)));
}

TEST(TraceCsvTest, CrlfAndBomAccepted) {
  const std::string path = write_text("t.csv", "\xEF\xBB\xBFt,x,y,z\r\n0,1,2,3\r\n1,4,5,6\r\n");
  const Trace trace = read_csv_trace(path);
  ASSERT_EQ(trace.time_s.size(), 2u);
  EXPECT_EQ(trace.time_s[1], 1.0);
  EXPECT_EQ(trace.position_mm[1], Vec3d(4, 5, 6));
}

struct BadCsv {
  const char* name;
  const char* text;
  const char* problem;
};

// Names the case in test listings instead of dumping the struct's bytes.
void PrintTo(const BadCsv& bad, std::ostream* out) { *out << bad.name; }

class TraceCsvErrorTest : public ::testing::TestWithParam<BadCsv> {};

TEST_P(TraceCsvErrorTest, NamesFileAndProblem) {
  const BadCsv& bad = GetParam();
  const std::string path = write_text(std::string(bad.name) + ".csv", bad.text);
  const std::string what = input_error_of([&] { read_csv_trace(path); });
  EXPECT_THAT(what, HasSubstr(path + ": ")) << what;
  EXPECT_THAT(what, HasSubstr(bad.problem)) << what;
}

INSTANTIATE_TEST_SUITE_P(
    Trace, TraceCsvErrorTest,
    ::testing::Values(
        BadCsv{"empty", "", "empty file: no header row"},
        BadCsv{"blank", "\n  \n# only comments\n", "empty file: no header row"},
        BadCsv{"missing_column", "t,a,b\n0,1,2\n", "missing column 'x' (columns are: t, a, b)"},
        BadCsv{"few_fields", "t,x,y,z\n0,1,2,3\n1,2,3\n", "line 3: expected 4 fields, found 3"},
        BadCsv{"many_fields", "t,x,y,z\n0,1,2,3,4\n", "line 2: expected 4 fields, found 5"},
        BadCsv{"not_number", "t,x,y,z\n0,0,0,0\n1,0,0,0\n\n# c\n\n2,0,abc,0\n",
               "line 7: column 'y': not a number: 'abc'"},
        BadCsv{"trailing_junk", "t,x,y,z\n0,0,0,0\n1,0,0,1.5mm\n",
               "line 3: column 'z': not a number: '1.5mm'"},
        BadCsv{"empty_field", "t,x,y,z\n0,,0,0\n", "line 2: column 'x': not a number: ''"},
        BadCsv{"nan", "t,x,y,z\n0,0,0,0\n1,0,0,0\n2,0,0,0\n3,0,0,0\n4,0,0,0\n5,0,nan,0\n",
               "line 7: column 'y': NaN or infinite value"},
        BadCsv{"inf", "t,x,y,z\n0,0,0,0\ninf,0,0,0\n", "line 3: column 't': NaN or infinite value"},
        BadCsv{"time_repeats",
               "t,x,y,z\n0,0,0,0\n0.1,0,0,0\n0.2,0,0,0\n0.3,0,0,0\n0.4,0,0,0\n"
               "0.45,0,0,0\n0.5,0,0,0\n0.5,0,0,0\n",
               "line 9: time 0.5 does not increase (previous 0.5)"},
        BadCsv{"time_decreases", "t,x,y,z\n1,0,0,0\n0.5,0,0,0\n",
               "line 3: time 0.5 does not increase (previous 1)"},
        BadCsv{"one_sample", "t,x,y,z\n0,0,0,0\n", "need at least 2 samples, found 1"},
        BadCsv{"no_samples", "t,x,y,z\n", "need at least 2 samples, found 0"}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(TraceCsvTest, AColumnNamedTwiceIsRefusedNamingIt) {
  // Which 'x' was read depended on a search's order; now the header is refused.
  const std::string path = write_text("twice.csv", "t,x,y,z,x\n0,1,2,3,4\n1,1,2,3,4\n");
  EXPECT_EQ(input_error_of([&] { read_csv_trace(path); }),
            path + ": column 'x' appears twice in the header (columns 2 and 5)");
  // Unnamed columns (a trailing comma or two) are no names to confuse.
  const std::string unnamed = write_text("unnamed.csv", "t,x,y,z,,\n0,1,2,3,,\n1,1,2,3,,\n");
  EXPECT_EQ(read_csv_trace(unnamed).time_s.size(), 2u);
}

TEST(TraceCsvTest, MissingFile) {
  const std::string path = hapvox::testing::scratch_dir() + "/nope.csv";
  const std::string what = input_error_of([&] { read_trace(path); });
  EXPECT_EQ(what, path + ": cannot open file");
}

TEST(TraceCsvTest, NonPositiveScalesRejected) {
  const std::string path = write_text("t.csv", "t,x,y,z\n0,0,0,0\n1,0,0,0\n");
  TraceColumns columns;
  columns.seconds_per_time_unit = 0.0;
  EXPECT_THAT(input_error_of([&] { read_csv_trace(path, columns); }),
              HasSubstr(path + ": time scale must be positive"));
  columns.seconds_per_time_unit = 1.0;
  columns.mm_per_position_unit = -1.0;
  EXPECT_THAT(input_error_of([&] { read_csv_trace(path, columns); }),
              HasSubstr(path + ": position scale must be positive"));
}

// --- HDF5 ---------------------------------------------------------------------------------

// Writes float64 datasets; each entry is a name and its values, shaped by `dims`.
void write_h5(const std::string& path,
              const std::vector<std::pair<std::string, std::vector<double>>>& datasets,
              const std::vector<hsize_t>& dims_2d = {}) {
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  for (const auto& [name, values] : datasets) {
    std::vector<hsize_t> dims = {values.size()};
    if (!dims_2d.empty() && name == "x") dims = dims_2d;
    const hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
    const hid_t set = H5Dcreate2(file, name.c_str(), H5T_IEEE_F64LE, space, H5P_DEFAULT,
                                 H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()), 0);
    H5Dclose(set);
    H5Sclose(space);
  }
  H5Fclose(file);
}

TEST(TraceH5Test, RoundTripIsExact) {
  const std::string path = hapvox::testing::scratch_dir() + "/trace.h5";
  const Trace trace = awkward_trace();
  write_h5_trace(trace, path);
  EXPECT_FALSE(std::filesystem::exists(path + ".partial"));
  expect_bit_equal(read_h5_trace(path), trace);
  expect_bit_equal(read_trace(path), trace);
}

TEST(TraceH5Test, CustomDatasetNamesAndUnits) {
  const std::string path = hapvox::testing::scratch_dir() + "/custom.hdf5";
  write_h5(path, {{"time", {0, 10, 20}},
                  {"a", {1, 2, 3}},
                  {"b", {4, 5, 6}},
                  {"c", {7, 8, 9}},
                  {"other", {1}}});
  TraceColumns columns;
  columns.time = "time";
  columns.position = {"a", "b", "c"};
  columns.seconds_per_time_unit = 1e-3;
  const Trace trace = read_trace(path, columns);
  ASSERT_EQ(trace.time_s.size(), 3u);
  EXPECT_DOUBLE_EQ(trace.time_s[2], 0.02);
  EXPECT_EQ(trace.position_mm[1], Vec3d(2, 5, 8));
}

TEST(TraceH5Test, IntegerDatasetsConverted) {
  const std::string path = hapvox::testing::scratch_dir() + "/ints.h5";
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  const std::vector<int> values = {0, 1, 2};
  const hsize_t n = values.size();
  for (const char* name : {"t", "x", "y", "z"}) {
    const hid_t space = H5Screate_simple(1, &n, nullptr);
    const hid_t set =
        H5Dcreate2(file, name, H5T_STD_I32LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Dwrite(set, H5T_NATIVE_INT, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
    H5Dclose(set);
    H5Sclose(space);
  }
  H5Fclose(file);
  const Trace trace = read_h5_trace(path);
  ASSERT_EQ(trace.time_s.size(), 3u);
  EXPECT_EQ(trace.position_mm[2], Vec3d(2, 2, 2));
}

TEST(TraceH5Test, BadFilesNameFileAndProblem) {
  const std::string dir = hapvox::testing::scratch_dir();
  const auto expect_error = [](const std::string& path, const std::string& problem) {
    const std::string what = input_error_of([&] { read_h5_trace(path); });
    EXPECT_THAT(what, HasSubstr(path + ": " + problem)) << what;
  };
  const std::vector<double> t = {0, 1, 2};
  const std::vector<double> v = {0, 0, 0};

  expect_error(dir + "/missing.h5", "cannot open file");
  const std::string text = dir + "/text.h5";
  std::ofstream(text) << "t,x,y,z\n";
  expect_error(text, "not an HDF5 file");

  const std::string no_z = dir + "/no_z.h5";
  write_h5(no_z, {{"t", t}, {"x", v}, {"y", v}});
  expect_error(no_z, "missing dataset 'z'");

  const std::string rank2 = dir + "/rank2.h5";
  write_h5(rank2, {{"t", t}, {"x", {0, 0, 0, 0, 0, 0}}, {"y", v}, {"z", v}}, {3, 2});
  expect_error(rank2, "dataset 'x' is not 1-D (rank 2)");

  const std::string short_y = dir + "/short.h5";
  write_h5(short_y, {{"t", t}, {"x", v}, {"y", {0, 0}}, {"z", v}});
  expect_error(short_y, "dataset 'y' has 2 values but dataset 't' has 3");

  const std::string nan = dir + "/nan.h5";
  write_h5(nan, {{"t", t}, {"x", v}, {"y", v}, {"z", {0, 0, std::nan("")}}});
  expect_error(nan, "index 2: dataset 'z': NaN or infinite value");

  const std::string repeat = dir + "/repeat.h5";
  write_h5(repeat, {{"t", {0, 0.5, 0.5}}, {"x", v}, {"y", v}, {"z", v}});
  expect_error(repeat, "index 2: time 0.5 does not increase (previous 0.5)");

  const std::string one = dir + "/one.h5";
  write_h5(one, {{"t", {0}}, {"x", {0}}, {"y", {0}}, {"z", {0}}});
  expect_error(one, "need at least 2 samples, found 1");
}

// --- Transforms -----------------------------------------------------------------------------

// Times 0 and 1 s; the tests set the positions.
Trace two_samples() {
  Trace trace;
  trace.time_s = {0.0, 1.0};
  trace.position_mm = {Vec3d::Zero(), Vec3d::Zero()};
  return trace;
}

TEST(TraceTransformTest, EulerRotationOrder) {
  const Eigen::Matrix3d rx = rotation_from_euler_deg(Vec3d(90, 0, 0));
  EXPECT_TRUE((rx * Vec3d::UnitY()).isApprox(Vec3d::UnitZ()));
  // x first, then z: y -> z (about x) -> z (about z).
  const Eigen::Matrix3d rxz = rotation_from_euler_deg(Vec3d(90, 0, 90));
  EXPECT_TRUE((rxz * Vec3d::UnitY()).isApprox(Vec3d::UnitZ()));
  EXPECT_TRUE((rxz * Vec3d::UnitX()).isApprox(Vec3d::UnitY()));
  EXPECT_TRUE((rotation_from_euler_deg(Vec3d(0, 90, 0)) * Vec3d::UnitZ()).isApprox(Vec3d::UnitX()));
}

TEST(TraceTransformTest, ApplyScalesRotatesThenOffsets) {
  DeviceTransform transform;
  transform.scale = 2.0;
  transform.rotation = rotation_from_euler_deg(Vec3d(0, 0, 90));
  transform.offset_mm = Vec3d(10, 20, 30);
  EXPECT_TRUE(transform.apply(Vec3d(1, 0, 0)).isApprox(Vec3d(10, 22, 30)));
}

TEST(TraceTransformTest, FitIntoBoxTouchesLimitingAxis) {
  Trace trace = two_samples();
  trace.position_mm = {Vec3d(-5, 0, 100), Vec3d(15, 4, 102)};  // extent 20 x 4 x 2
  const Vec3d box_min(0, 0, 0);
  const Vec3d box_max(100, 50, 50);
  const double margin = 0.1;
  const DeviceTransform fit = fit_trace_into_box(trace, box_min, box_max, margin);
  EXPECT_DOUBLE_EQ(fit.scale, 80.0 / 20.0);
  Vec3d lo = fit.apply(trace.position_mm[0]);
  Vec3d hi = lo;
  for (const Vec3d& p : trace.position_mm) {
    lo = lo.cwiseMin(fit.apply(p));
    hi = hi.cwiseMax(fit.apply(p));
  }
  const Vec3d inner_min = box_min + margin * (box_max - box_min);
  const Vec3d inner_max = box_max - margin * (box_max - box_min);
  EXPECT_TRUE((lo.array() >= inner_min.array() - 1e-9).all());
  EXPECT_TRUE((hi.array() <= inner_max.array() + 1e-9).all());
  EXPECT_NEAR(lo.x(), inner_min.x(), 1e-9);  // x limits the scale
  EXPECT_NEAR(hi.x(), inner_max.x(), 1e-9);
  EXPECT_TRUE((0.5 * (lo + hi)).isApprox(0.5 * (box_min + box_max)));
}

TEST(TraceTransformTest, FitFlatAndStillTraces) {
  Trace flat = two_samples();
  flat.position_mm = {Vec3d(0, 0, 5), Vec3d(0, 2, 5)};  // extent only along y
  const DeviceTransform fit = fit_trace_into_box(flat, Vec3d(0, 0, 0), Vec3d(10, 10, 10), 0.0);
  EXPECT_DOUBLE_EQ(fit.scale, 5.0);
  EXPECT_TRUE(fit.apply(Vec3d(0, 0, 5)).isApprox(Vec3d(5, 0, 5)));
  EXPECT_TRUE(fit.apply(Vec3d(0, 2, 5)).isApprox(Vec3d(5, 10, 5)));

  Trace still = two_samples();
  still.position_mm = {Vec3d(1, 2, 3), Vec3d(1, 2, 3)};
  const DeviceTransform centre = fit_trace_into_box(still, Vec3d(0, 0, 0), Vec3d(10, 20, 30));
  EXPECT_EQ(centre.scale, 1.0);
  EXPECT_TRUE(centre.apply(Vec3d(1, 2, 3)).isApprox(Vec3d(5, 10, 15)));
}

// --- Synthetic traces -----------------------------------------------------------------------

TEST(TraceMakeTest, ParseShape) {
  EXPECT_EQ(parse_trace_shape("press", "--shape"), TraceShape::kPress);
  EXPECT_EQ(parse_trace_shape("press-release", "--shape"), TraceShape::kPressRelease);
  EXPECT_EQ(parse_trace_shape("stroke", "--shape"), TraceShape::kStroke);
  EXPECT_EQ(parse_trace_shape("circle", "--shape"), TraceShape::kCircle);
  EXPECT_THAT(input_error_of([] { parse_trace_shape("spiral", "--shape"); }),
              HasSubstr("--shape: unknown trace shape 'spiral'"));
}

// Checks the sampling grid and continuity, and returns the largest distance from start
// along `direction`.
double check_common(const Trace& trace, const TraceMakeOptions& o) {
  EXPECT_GE(trace.time_s.size(), 2u);
  EXPECT_EQ(trace.time_s.size(), trace.position_mm.size());
  const double step = o.speed_mm_s / o.rate_hz;
  double max_travel = 0.0;
  for (std::size_t k = 0; k < trace.time_s.size(); ++k) {
    EXPECT_EQ(trace.time_s[k], static_cast<double>(k) / o.rate_hz);
    if (k > 0) {
      EXPECT_LE((trace.position_mm[k] - trace.position_mm[k - 1]).norm(), step + 1e-9) << k;
    }
    max_travel =
        std::max(max_travel, (trace.position_mm[k] - o.start_mm).dot(o.direction.normalized()));
  }
  EXPECT_EQ(trace.position_mm.front(), o.start_mm);
  return max_travel;
}

// Counts samples whose step from the previous one is exactly speed / rate; straight
// segments must produce many.
int constant_speed_steps(const Trace& trace, const TraceMakeOptions& o) {
  int count = 0;
  for (std::size_t k = 1; k < trace.position_mm.size(); ++k) {
    const double d = (trace.position_mm[k] - trace.position_mm[k - 1]).norm();
    if (std::abs(d - o.speed_mm_s / o.rate_hz) < 1e-9) ++count;
  }
  return count;
}

TEST(TraceMakeTest, Press) {
  TraceMakeOptions o;
  o.shape = TraceShape::kPress;
  o.start_mm = Vec3d(1, 2, 3);
  o.direction = Vec3d(0, 0, -2);
  o.travel_mm = 5.0;
  o.speed_mm_s = 20.0;
  o.hold_s = 0.1;
  const Trace trace = make_trace(o);
  EXPECT_NEAR(check_common(trace, o), 5.0, 1e-12);
  EXPECT_TRUE(trace.position_mm.back().isApprox(Vec3d(1, 2, -2)));
  // 0.25 s down plus 0.1 s hold.
  EXPECT_NEAR(trace.time_s.back(), 0.35, 1e-9);
  // Every step of the descent is speed / rate.
  for (std::size_t k = 1; k <= 250; ++k) {
    EXPECT_NEAR((trace.position_mm[k] - trace.position_mm[k - 1]).norm(), 0.02, 1e-9) << k;
  }
  for (std::size_t k = 251; k < trace.position_mm.size(); ++k) {
    EXPECT_EQ(trace.position_mm[k], trace.position_mm[250]) << k;
  }
}

TEST(TraceMakeTest, PressReleaseReturnsToStart) {
  TraceMakeOptions o;  // defaults: 10 mm at 10 mm/s, hold 0.5 s, 1 kHz
  o.start_mm = Vec3d(0, 0, 20);
  const Trace trace = make_trace(o);
  EXPECT_NEAR(check_common(trace, o), 10.0, 1e-12);
  EXPECT_EQ(trace.position_mm.back(), o.start_mm);
  EXPECT_NEAR(trace.time_s.back(), 2.5, 1e-9);
  EXPECT_GE(constant_speed_steps(trace, o), 1990);
}

TEST(TraceMakeTest, StrokeMovesLaterallyAndLifts) {
  TraceMakeOptions o;
  o.shape = TraceShape::kStroke;
  o.lateral = Vec3d(1, 0, 1);  // not perpendicular: the z part is removed
  o.rate_hz = 500.0;
  const Trace trace = make_trace(o);
  EXPECT_NEAR(check_common(trace, o), 10.0, 1e-12);
  EXPECT_TRUE(trace.position_mm.back().isApprox(Vec3d(20, 0, 0)));
  EXPECT_NEAR(trace.time_s.back(), 4.0, 1e-9);
  EXPECT_GE(constant_speed_steps(trace, o), 1990);
  // Mid-stroke the tool is at full depth.
  EXPECT_TRUE(trace.position_mm[1000].isApprox(Vec3d(10, 0, -10)));
}

TEST(TraceMakeTest, CircleRadiusAndReturn) {
  TraceMakeOptions o;
  o.shape = TraceShape::kCircle;
  o.radius_mm = 5.0;
  o.speed_mm_s = 25.0;
  const Trace trace = make_trace(o);
  EXPECT_NEAR(check_common(trace, o), 10.0, 1e-12);
  EXPECT_EQ(trace.position_mm.back(), o.start_mm);
  const double down_s = 0.4;
  const double circle_s = 2.0 * std::numbers::pi * 5.0 / 25.0;
  EXPECT_NEAR(trace.time_s.back(), down_s + circle_s + down_s, 1e-3);
  const Vec3d bottom(0, 0, -10);
  const Vec3d centre = bottom + 5.0 * Vec3d::UnitX();
  int on_circle = 0;
  for (std::size_t k = 0; k < trace.time_s.size(); ++k) {
    const double t = trace.time_s[k];
    if (t > down_s + 1e-9 && t < down_s + circle_s - 1e-9) {
      EXPECT_NEAR((trace.position_mm[k] - centre).norm(), 5.0, 1e-9) << k;
      EXPECT_NEAR(trace.position_mm[k].z(), -10.0, 1e-12) << k;
      ++on_circle;
    }
  }
  EXPECT_GT(on_circle, 1200);
  // Half way round is the point opposite the bottom.
  const std::size_t half = static_cast<std::size_t>(std::round((down_s + circle_s / 2) * 1000));
  EXPECT_NEAR((trace.position_mm[half] - (bottom + 10.0 * Vec3d::UnitX())).norm(), 0.0, 0.03);
}

TEST(TraceMakeTest, SamplesEndOffGridAtTheEndPoint) {
  TraceMakeOptions o;
  o.travel_mm = 1.0;
  o.speed_mm_s = 3.0;  // 1/3 s: not a whole number of 1 kHz samples
  o.hold_s = 0.0;
  const Trace trace = make_trace(o);
  check_common(trace, o);
  EXPECT_EQ(trace.position_mm.back(), o.start_mm);
  EXPECT_EQ(trace.time_s.size(), 668u);  // ceil(666.67) + 1
}

TEST(TraceMakeTest, BadOptions) {
  const auto expect_error = [](auto change, const std::string& problem) {
    TraceMakeOptions o;
    change(o);
    EXPECT_THAT(input_error_of([&] { make_trace(o); }), HasSubstr("trace make: " + problem));
  };
  expect_error([](TraceMakeOptions& o) { o.speed_mm_s = 0; }, "speed must be positive");
  expect_error([](TraceMakeOptions& o) { o.rate_hz = -5; }, "rate must be positive");
  expect_error([](TraceMakeOptions& o) { o.travel_mm = 0; }, "travel must be positive");
  expect_error([](TraceMakeOptions& o) { o.direction = Vec3d::Zero(); }, "direction");
  expect_error(
      [](TraceMakeOptions& o) {
        o.shape = TraceShape::kStroke;
        o.lateral = Vec3d(0, 0, 3);
      },
      "lateral must not be zero or parallel");
  expect_error(
      [](TraceMakeOptions& o) {
        o.shape = TraceShape::kCircle;
        o.radius_mm = 0;
      },
      "radius must be positive");
}

}  // namespace
}  // namespace hapvox::haptics
