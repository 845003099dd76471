// TetGen's files (engine/proxy/tetgen_files.h): a mesh written as .node/.ele reads back
// identical; TetGen's own conventions (indices from 1, the other orientation, markers) read
// as positive tets; the .smesh surface holds exactly the outer and label-boundary faces; and
// a malformed file is one error naming its line.

#include "engine/proxy/tetgen_files.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "engine/errors.h"
#include "test_data.h"

namespace hapvox::engine::proxy {
namespace {

// The lattice of 4 x 4 x 4 cubes of 2 mm, label 1 for x < 4 mm and 2 beyond (whole cubes).
fem::TetMesh two_labels() {
  fem::TetMesh mesh = fem::regular_lattice({5, 5, 5}, 2.0, Eigen::Vector3d::Zero());
  for (int t = 0; t < mesh.tet_count(); ++t) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const std::int32_t v : mesh.tets[t]) c += 0.25 * mesh.rest_mm.col(v);
    mesh.labels[t] = c.x() < 4.0 ? 1 : 2;
  }
  // Irrational-looking coordinates: the round trip must keep every bit.
  mesh.rest_mm *= 1.0 / 3.0;
  return mesh;
}

std::string write(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
  return path;
}

TEST(TetgenFiles, AMeshWrittenAsNodeAndEleReadsBackIdentical) {
  const std::string dir = testing::scratch_dir();
  const fem::TetMesh mesh = two_labels();
  write_tetgen_mesh(dir + "/m", mesh);
  const fem::TetMesh back = read_tetgen_mesh(dir + "/m");
  EXPECT_EQ(back.rest_mm, mesh.rest_mm);
  EXPECT_EQ(back.tets, mesh.tets);
  EXPECT_EQ(back.labels, mesh.labels);
}

TEST(TetgenFiles, TetgensIndicesFromOneAndItsOrientationReadAsPositiveTets) {
  const std::string dir = testing::scratch_dir();
  // One unit tet as TetGen writes it: 1-based, a boundary marker per point, no attribute,
  // the fourth point below the first three's counter-clockwise face.
  write(dir + "/t.node", "# from tetgen\n4 3 0 1\n1 0 0 0 1\n2 1 0 0 1\n3 0 1 0 1\n4 0 0 1 1\n");
  write(dir + "/t.ele", "1 4 0\n  1  1 3 2 4  # comment\n");
  const fem::TetMesh mesh = read_tetgen_mesh(dir + "/t");
  ASSERT_EQ(mesh.tet_count(), 1);
  EXPECT_NEAR(
      fem::signed_volume_mm3(mesh.rest_mm.col(mesh.tets[0][0]), mesh.rest_mm.col(mesh.tets[0][1]),
                             mesh.rest_mm.col(mesh.tets[0][2]), mesh.rest_mm.col(mesh.tets[0][3])),
      1.0 / 6.0, 1e-15);
  EXPECT_EQ(mesh.labels, std::vector<std::int32_t>{0});
  fem::validate(mesh, "t");
}

TEST(TetgenFiles, TheSurfaceHoldsTheOuterFacesAndTheLabelBoundaryOnly) {
  const std::string dir = testing::scratch_dir();
  // 4 x 4 cube faces per side, 2 triangles each: 6 sides outside, and the plane x = 4 mm
  // between the labels.
  EXPECT_EQ(write_tetgen_surface(dir + "/s", two_labels()), 6 * 16 * 2 + 16 * 2);
  std::ifstream in(dir + "/s.smesh");
  std::string line;
  std::getline(in, line);  // comment
  int points = 0;
  in >> points;
  std::getline(in, line);
  for (int p = 0; p < points; ++p) std::getline(in, line);
  int facets = 0, markers = 0;
  in >> facets >> markers;
  ASSERT_EQ(markers, 1);
  int outer = 0, between = 0;
  for (int k = 0; k < facets; ++k) {
    int corners = 0, a = 0, b = 0, c = 0, marker = 0;
    in >> corners >> a >> b >> c >> marker;
    ASSERT_EQ(corners, 3);
    ASSERT_TRUE(a < points && b < points && c < points);
    (marker == 1 ? outer : between) += 1;
  }
  EXPECT_EQ(outer, 6 * 16 * 2);
  EXPECT_EQ(between, 16 * 2);
  // One label only: the outer surface alone.
  fem::TetMesh one = two_labels();
  std::fill(one.labels.begin(), one.labels.end(), 3);
  EXPECT_EQ(write_tetgen_surface(dir + "/one", one), 6 * 16 * 2);
}

void expect_error(const std::string& prefix, const std::string& expected) {
  try {
    read_tetgen_mesh(prefix);
    ADD_FAILURE() << "no error for " << prefix;
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), expected);
  }
}

TEST(TetgenFiles, AMalformedFileIsOneErrorNamingItsLine) {
  const std::string dir = testing::scratch_dir();
  const std::string node = "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n";
  expect_error(dir + "/none", dir + "/none.node: cannot open file");
  write(dir + "/a.node", node);
  write(dir + "/a.ele", "1 4 0\n0 0 1 2 9\n");
  expect_error(dir + "/a", dir + "/a.ele:2: point 9 is not in " + dir + "/a.node");
  write(dir + "/b.node", "4 2 0 0\n");
  expect_error(dir + "/b", dir + "/b.node:1: the dimension must be 3");
  write(dir + "/c.node", "4 3 0 0\n0 0 0 0\n1 1 0 x\n");
  expect_error(dir + "/c", dir + "/c.node:3: expected a coordinate, got 'x'");
  write(dir + "/d.node", "4 3 0 0\n0 0 0 0\n");
  expect_error(dir + "/d", dir + "/d.node: ends before its last point");
  write(dir + "/e.node", node);
  write(dir + "/e.ele", "1 10 0\n");
  expect_error(dir + "/e", dir + "/e.ele:1: only 4-node tets are read (no -o2)");
  write(dir + "/f.node", node);
  write(dir + "/f.ele", "1 4 0\n0 0 1 2 2\n");
  expect_error(dir + "/f", dir + "/f.ele:2: a tet with no volume");
  write(dir + "/g.node", "2 3 0 0\n0 0 0 0\n2 1 0 0\n");
  expect_error(dir + "/g", dir + "/g.node:3: points must be numbered in order");
  // A header asking for 2^31 - 1 points allocates nothing before the points are there.
  write(dir + "/i.node", "2147483647 3 0 0\n0 0 0 0\n");
  expect_error(dir + "/i", dir + "/i.node: ends before its last point");
  write(dir + "/h.node", node);
  write(dir + "/h.ele", "1 4 1\n0 0 1 2 3 1.5\n");
  expect_error(dir + "/h", dir + "/h.ele:2: the region attribute must be an integer label");
}

}  // namespace
}  // namespace hapvox::engine::proxy
