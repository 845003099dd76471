#include "render/slice_mesh.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

namespace hapvox::render {
namespace {

using Eigen::Vector3d;

double polygon_area(const std::vector<Vector3d>& p) {
  Vector3d sum = Vector3d::Zero();
  for (std::size_t i = 1; i + 1 < p.size(); ++i) sum += (p[i] - p[0]).cross(p[i + 1] - p[0]);
  return 0.5 * sum.norm();
}

TEST(SlicePolygon, CutsTheBoxExactly) {
  const Vector3d lo(0, 0, 0), hi(2, 3, 4);
  // Axis-aligned: a 2 x 3 rectangle at every height.
  const auto flat = slice_polygon(lo, hi, Vector3d::UnitZ(), 1.5);
  ASSERT_EQ(flat.size(), 4u);
  EXPECT_NEAR(polygon_area(flat), 6.0, 1e-12);
  for (const auto& p : flat) EXPECT_NEAR(p.z(), 1.5, 1e-12);
  // Through the centre along the diagonal of a cube: a regular hexagon.
  const Vector3d n = Vector3d(1, 1, 1).normalized();
  const auto hexagon =
      slice_polygon(Vector3d::Zero(), Vector3d::Ones(), n, n.dot(Vector3d::Constant(0.5)));
  ASSERT_EQ(hexagon.size(), 6u);
  EXPECT_NEAR(polygon_area(hexagon), 3.0 * std::sqrt(3.0) / 4.0, 1e-9);
  // Outside the box: nothing.
  EXPECT_TRUE(slice_polygon(lo, hi, Vector3d::UnitZ(), 5.0).empty());
}

TEST(SlicePolygon, SlicesSumToTheBoxVolume) {
  // Property: for any direction, area x spacing over all slices is the box's volume.
  const Vector3d lo(-1, 0, 2), hi(3, 2, 5);
  for (const Vector3d& d : {Vector3d(0.3, -0.5, 0.8), Vector3d(1, 2, 3), Vector3d(-1, 0.1, 0)}) {
    const Vector3d n = d.normalized();
    double s0 = INFINITY, s1 = -INFINITY;
    for (int k = 0; k < 8; ++k) {
      const Vector3d c((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(),
                       (k & 4) ? hi.z() : lo.z());
      s0 = std::min(s0, n.dot(c)), s1 = std::max(s1, n.dot(c));
    }
    const int slices = 2000;
    const double ds = (s1 - s0) / slices;
    double volume = 0.0;
    for (int i = 0; i < slices; ++i)
      volume += polygon_area(slice_polygon(lo, hi, n, s0 + (i + 0.5) * ds)) * ds;
    EXPECT_NEAR(volume, 24.0, 24.0 * 1e-4);
  }
}

TEST(FfdKernel, WendlandIsOneAtTheToolZeroBeyondItsSupportAndContinuous) {
  SliceMeshOptions options;
  options.kernel = FfdKernel::kWendland;
  const double R = 6.0;
  EXPECT_DOUBLE_EQ(ffd_weight(0.0, options, R), 1.0);
  EXPECT_DOUBLE_EQ(ffd_weight(R, options, R), 0.0);
  EXPECT_DOUBLE_EQ(ffd_weight(2 * R, options, R), 0.0);
  double previous = 1.0;
  for (double d = 0.01; d < R; d += 0.01) {
    const double w = ffd_weight(d, options, R);
    EXPECT_LT(w, previous);               // strictly falling
    EXPECT_LT(previous - w, 0.01 * 2.0);  // no step (|w'| <= 20/(9R)... < 2)
    previous = w;
  }
  EXPECT_LT(ffd_weight(R - 1e-6, options, R), 1e-12);  // smooth landing at R
}

TEST(FfdKernel, PaperFallsAsOneOverDistanceFromTheToolSurface) {
  SliceMeshOptions options;
  options.kernel = FfdKernel::kPaper;
  options.voxel_mm = 0.5;
  EXPECT_DOUBLE_EQ(ffd_weight(0.0, options, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(ffd_weight(0.5, options, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(ffd_weight(2.0, options, 0.0), 0.25);
  EXPECT_DOUBLE_EQ(ffd_weight(50.0, options, 0.0), 0.01);
}

ToolPose pressing_tool() {
  ToolPose tool;
  tool.center_mm = Vector3d(10, 10, 10);
  tool.radius_mm = 2.0;
  tool.displacement_mm = Vector3d(0, 0, -1.5);
  tool.in_contact = true;
  return tool;
}

TEST(FfdDisplace, MovesTheToolsNeighbourhoodByUAndNothingFarAway) {
  const ToolPose tool = pressing_tool();
  SliceMeshOptions options;  // Wendland, R = 3 radii = 6 mm
  // Inside the tool and on its surface: the full displacement.
  EXPECT_TRUE(
      ffd_displace(tool.center_mm, tool, options).isApprox(tool.center_mm + tool.displacement_mm));
  const Vector3d on_surface = tool.center_mm + Vector3d(0, 2, 0);
  EXPECT_TRUE(ffd_displace(on_surface, tool, options).isApprox(on_surface + tool.displacement_mm));
  // Beyond radius + support: exactly still.
  const Vector3d far = tool.center_mm + Vector3d(8.01, 0, 0);
  EXPECT_EQ(ffd_displace(far, tool, options), far);
  // Displacement is along u, never beyond it.
  const Vector3d p = tool.center_mm + Vector3d(3, 1, -2);
  const Vector3d moved = ffd_displace(p, tool, options) - p;
  EXPECT_NEAR(moved.normalized().dot(tool.displacement_mm.normalized()), 1.0, 1e-12);
  EXPECT_LT(moved.norm(), tool.displacement_mm.norm());
  // Out of contact nothing moves.
  ToolPose free = tool;
  free.in_contact = false;
  EXPECT_EQ(ffd_displace(tool.center_mm, free, options), tool.center_mm);
}

TEST(FfdDisplace, WeightGradientIsTheDerivativeOfTheWeight) {
  const ToolPose tool = pressing_tool();
  for (FfdKernel kernel : {FfdKernel::kWendland, FfdKernel::kPaper}) {
    SliceMeshOptions options;
    options.kernel = kernel;
    for (const Vector3d& offset : {Vector3d(3, 1, -2), Vector3d(0.5, -4, 1), Vector3d(1, 1, 1)}) {
      const Vector3d p = tool.center_mm + offset;
      const double h = 1e-6;
      Vector3d numeric;
      for (int a = 0; a < 3; ++a) {
        const Vector3d e = Vector3d::Unit(a) * h;
        const double up = (ffd_displace(p + e, tool, options) - (p + e)).dot(tool.displacement_mm);
        const double down =
            (ffd_displace(p - e, tool, options) - (p - e)).dot(tool.displacement_mm);
        numeric[a] = (up - down) / (2 * h) / tool.displacement_mm.squaredNorm();
      }
      EXPECT_LT((ffd_weight_gradient(p, tool, options) - numeric).norm(), 1e-5)
          << offset.transpose();
    }
  }
}

// Mean depth along n of each triangle, in index order.
std::vector<double> triangle_depths(const SliceMesh& mesh, const Vector3d& n) {
  std::vector<double> depths;
  for (std::size_t i = 0; i < mesh.indices.size(); i += 3) {
    double d = 0.0;
    for (int k = 0; k < 3; ++k) {
      const SliceVertex& v = mesh.vertices[mesh.indices[i + k]];
      d += n.dot(Vector3d(v.rest[0], v.rest[1], v.rest[2])) / 3.0;
    }
    depths.push_back(d);
  }
  return depths;
}

TEST(SliceMesh, SlicesComeBackToFrontAndCoverTheBox) {
  const Vector3d lo(0, 0, 0), hi(20, 20, 20);
  const Vector3d view = Vector3d(-0.4, 0.7, -0.6).normalized();
  SliceMeshOptions options;
  options.slices = 64;
  SliceMesh mesh;
  build_slice_mesh(lo, hi, lo, hi, view, ToolPose{}, options, mesh);
  EXPECT_EQ(mesh.slices, 64);
  const std::vector<double> depths = triangle_depths(mesh, view);
  ASSERT_FALSE(depths.empty());
  for (std::size_t i = 1; i < depths.size(); ++i) EXPECT_LE(depths[i], depths[i - 1] + 1e-6);
  // Undisplaced: positions equal rest positions and all lie inside the box.
  for (const SliceVertex& v : mesh.vertices) {
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(v.position[a], v.rest[a]);
      EXPECT_GE(v.rest[a], lo[a] - 1e-4);
      EXPECT_LE(v.rest[a], hi[a] + 1e-4);
    }
  }
}

TEST(SliceMesh, SlicePlanesStayOnTheVolumesLatticeWhateverTheVisibleBox) {
  const Vector3d lo(0, 0, 0), hi(20, 20, 20);
  const Vector3d view = Vector3d(0.2, 0.3, -0.9).normalized();
  SliceMeshOptions options;
  options.slices = 50;
  SliceMesh whole, part;
  build_slice_mesh(lo, hi, lo, hi, view, ToolPose{}, options, whole);
  build_slice_mesh(lo, hi, Vector3d(5, 5, 5), Vector3d(12, 14, 9), view, ToolPose{}, options, part);
  EXPECT_LT(part.slices, whole.slices);
  EXPECT_DOUBLE_EQ(part.slice_spacing_mm, whole.slice_spacing_mm);
  // Every plane of the part is a plane of the whole: depth / spacing is k + 1/2 off the top.
  double top = -INFINITY;
  for (const SliceVertex& v : whole.vertices)
    top = std::max(top, view.dot(Vector3d(v.rest[0], v.rest[1], v.rest[2])));
  for (const SliceVertex& v : part.vertices) {
    const double k =
        (view.dot(Vector3d(v.rest[0], v.rest[1], v.rest[2])) - top) / part.slice_spacing_mm;
    EXPECT_NEAR(k - std::round(k), 0.0, 0.02);
  }
}

TEST(SliceMesh, AdaptiveMovesTheSameVerticesAsFfdWithFarFewerOfThem) {
  const Vector3d lo(0, 0, 0), hi(40, 40, 40);
  const Vector3d view = Vector3d(0.3, -0.2, -0.93).normalized();
  const ToolPose tool = pressing_tool();
  SliceMeshOptions adaptive;
  adaptive.slices = 500;
  SliceMeshOptions uniform = adaptive;
  uniform.tessellation = Tessellation::kUniform;
  SliceMesh a, u;
  build_slice_mesh(lo, hi, lo, hi, view, tool, adaptive, a);
  build_slice_mesh(lo, hi, lo, hi, view, tool, uniform, u);
  EXPECT_EQ(u.vertices.size(), 500u * 21 * 21);  // the paper's naive mesh
  // Fewer vertices although its cells near the tool (R/8 = 0.75 mm) are finer than the
  // naive mesh's (2 mm).
  EXPECT_LT(a.vertices.size() * 3, u.vertices.size());
  // Every vertex of both meshes sits where the deformation function puts it.
  std::size_t moved = 0;
  for (const SliceMesh* mesh : {&a, &u}) {
    for (const SliceVertex& v : mesh->vertices) {
      const Vector3d rest(v.rest[0], v.rest[1], v.rest[2]);
      const Vector3d expected = ffd_displace(rest, tool, adaptive);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(v.position[k], expected[k], 1e-4);
      const Vector3d gradient = ffd_weight_gradient(rest, tool, adaptive);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(v.weight_gradient[k], gradient[k], 1e-5);
      if ((expected - rest).norm() > 1e-3 && mesh == &a) ++moved;
    }
  }
  // The adaptive grid resolves the press: vertices within the support move.
  EXPECT_GT(moved, 100u);
}

// Largest distance, over every triangle's centroid and edge midpoints, between where the
// mesh's linear interpolation puts a rest point and where the FFD puts it.
double largest_interpolation_error_mm(const SliceMesh& mesh, const ToolPose& tool,
                                      const SliceMeshOptions& options) {
  const auto rest = [&](std::uint32_t i) {
    return Vector3d(mesh.vertices[i].rest[0], mesh.vertices[i].rest[1], mesh.vertices[i].rest[2]);
  };
  const auto position = [&](std::uint32_t i) {
    return Vector3d(mesh.vertices[i].position[0], mesh.vertices[i].position[1],
                    mesh.vertices[i].position[2]);
  };
  double largest = 0.0;
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const std::uint32_t* v = &mesh.indices[t];
    for (const Vector3d& b : {Vector3d(Vector3d::Constant(1.0 / 3.0)), Vector3d(0.5, 0.5, 0),
                              Vector3d(0, 0.5, 0.5), Vector3d(0.5, 0, 0.5)}) {
      const Vector3d r = b[0] * rest(v[0]) + b[1] * rest(v[1]) + b[2] * rest(v[2]);
      const Vector3d p = b[0] * position(v[0]) + b[1] * position(v[1]) + b[2] * position(v[2]);
      largest = std::max(largest, (ffd_displace(r, tool, options) - p).norm());
    }
  }
  return largest;
}

// Issue 29 point 5: cells near the tool grow as far as the interpolation bound
// 5 (h / R)^2 |u| allows, and the mesh keeps the displacement within max_error_mm of the
// kernel's. Here R = 6 mm and |u| = 1.5 mm, so R / 8 cells are within the bound's 0.117 mm
// (0.061 measured) and an error below that changes nothing; a bound of (h / R)^2 |u|, 5
// times too lax, would miss each error asked.
TEST(SliceMesh, CoarserCellsKeepTheDisplacementWithinTheErrorAsked) {
  const Vector3d lo(0, 0, 0), hi(40, 40, 40);
  const Vector3d view = Vector3d(0.3, -0.2, -0.93).normalized();
  const ToolPose tool = pressing_tool();
  SliceMeshOptions fine;
  fine.slices = 128;
  SliceMesh reference;
  build_slice_mesh(lo, hi, lo, hi, view, tool, fine, reference);
  EXPECT_LE(largest_interpolation_error_mm(reference, tool, fine), 5.0 / 64.0 * 1.5);
  for (const double error_mm : {0.15, 0.3, 0.6}) {
    SCOPED_TRACE(error_mm);
    SliceMeshOptions coarse = fine;
    coarse.max_error_mm = error_mm;
    SliceMesh mesh;
    build_slice_mesh(lo, hi, lo, hi, view, tool, coarse, mesh);
    EXPECT_LE(largest_interpolation_error_mm(mesh, tool, coarse), error_mm);
    EXPECT_LT(mesh.vertices.size(), reference.vertices.size());
    if (error_mm >= 0.6) {
      EXPECT_LT(mesh.vertices.size() * 3, reference.vertices.size());
    }
    std::printf("max error %.2f mm: %.3f mm measured, %zu vertices (R / 8: %zu)\n", error_mm,
                largest_interpolation_error_mm(mesh, tool, coarse), mesh.vertices.size(),
                reference.vertices.size());
  }
}

}  // namespace
}  // namespace hapvox::render
