#include "engine/proxy/incision_file.h"

#include <gtest/gtest.h>

#include <string>

#include "engine/errors.h"
#include "test_data.h"

namespace hapvox::engine::proxy {
namespace {

std::string error_of(const std::string& text) {
  try {
    parse_incision(text, "cut.toml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(IncisionFile, TheBundledFileIsAPolylineSweptDownThroughTheEngine) {
  const IncisionFile f = read_incision(testing::source_path("data/engine_incision.toml"));
  EXPECT_EQ(f.width_mm, 8.0);
  EXPECT_FALSE(f.at_s.has_value());
  ASSERT_EQ(f.cut.triangles_mm.size(), 2u);  // one segment: two triangles
  // The sweep carries the polyline's first point down 81 mm.
  EXPECT_EQ(f.cut.triangles_mm[1][2], Eigen::Vector3d(165, -2, 50));
}

TEST(IncisionFile, TrianglesAndATimeAreRead) {
  const IncisionFile f = parse_incision(
      "width_mm = 2.5\nat_s = 0.5\ntriangles_mm = [[[0, 0, 0], [10, 0, 0], [0, 10, 0]]]\n",
      "cut.toml");
  EXPECT_EQ(f.width_mm, 2.5);
  EXPECT_EQ(f.at_s, 0.5);
  ASSERT_EQ(f.cut.triangles_mm.size(), 1u);
  EXPECT_EQ(f.cut.triangles_mm[0][1], Eigen::Vector3d(10, 0, 0));
  EXPECT_EQ(f.source, "cut.toml");
}

TEST(IncisionFile, BadFilesAreOneLineErrorsWithTheirLine) {
  const std::string poly = "polyline_mm = [[0, 0, 0], [10, 0, 0]]\nsweep_mm = [0, 0, -5]\n";
  EXPECT_EQ(error_of(poly), "cut.toml: width_mm is missing");
  EXPECT_EQ(error_of("width_mm = 0\n" + poly), "cut.toml:1: width_mm must be > 0");
  EXPECT_EQ(error_of("width_mm = 'wide'\n" + poly), "cut.toml:1: width_mm must be a number");
  EXPECT_EQ(error_of("width_mm = nan\n" + poly), "cut.toml:1: width_mm must be finite");
  EXPECT_EQ(error_of("width_mm = 2\n"),
            "cut.toml: no cut: give polyline_mm (with sweep_mm) or triangles_mm");
  EXPECT_EQ(error_of("width_mm = 2\npolyline_mm = [[0, 0, 0], [10, 0, 0]]\n"),
            "cut.toml: polyline_mm needs sweep_mm");
  EXPECT_EQ(error_of("width_mm = 2\n" + poly + "triangles_mm = [[[0,0,0],[1,0,0],[0,1,0]]]\n"),
            "cut.toml:4: give polyline_mm or triangles_mm, not both");
  EXPECT_EQ(error_of("width_mm = 2\npolyline_mm = [[0, 0], [10, 0, 0]]\nsweep_mm = [0, 0, 1]\n"),
            "cut.toml:2: a polyline_mm point must be [x, y, z] (mm)");
  EXPECT_EQ(error_of("width_mm = 2\npolyline_mm = [[0, 0, 0], [0, 0, 5]]\nsweep_mm = [0, 0, 1]\n"),
            "cut.toml:2: the sweep is parallel to polyline segment 0");
  EXPECT_EQ(error_of("width_mm = 2\ntriangles_mm = [[[0, 0, 0], [1, 0, 0]]]\n"),
            "cut.toml:2: a triangle must be three [x, y, z] corners");
  EXPECT_EQ(error_of("width_mm = 2\ndepth = 3\n" + poly),
            "cut.toml:2: unknown key 'depth' (expected width_mm, polyline_mm, sweep_mm, "
            "triangles_mm, at_s)");
  EXPECT_EQ(error_of("width_mm = 2\nat_s = -1\n" + poly), "cut.toml:2: at_s must be >= 0 s");
  EXPECT_EQ(error_of("width_mm = = 2\n").rfind("cut.toml:1: ", 0), 0u);
}

TEST(IncisionFile, AMissingFileNamesItself) {
  try {
    read_incision("/nonexistent/cut.toml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/cut.toml: cannot open file");
  }
}

}  // namespace
}  // namespace hapvox::engine::proxy
