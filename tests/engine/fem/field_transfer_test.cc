// Point location and field transfer between meshes (engine/fem/field_transfer.h): weights
// reproduce the point, a linear field comes through exactly between two different meshes of
// one box, a point outside is extrapolated from the nearest tet, and a vertex of the old mesh
// takes that vertex's value.

#include "engine/fem/field_transfer.h"

#include <gtest/gtest.h>

#include "fem_fixtures.h"

namespace hapvox::engine::fem {
namespace {

Eigen::VectorXd linear_field(const Eigen::Matrix3Xd& points_mm) {
  Eigen::Matrix3d a;
  a << 0.02, -0.01, 0.005,  //
      0.003, 0.015, -0.02,  //
      -0.004, 0.007, 0.01;
  const Eigen::Vector3d b(0.3, -0.2, 0.1);
  Eigen::VectorXd u(3 * points_mm.cols());
  for (Eigen::Index p = 0; p < points_mm.cols(); ++p) {
    u.segment<3>(3 * p) = a * points_mm.col(p) + b;
  }
  return u;
}

// Two meshes of the box [0, 12]^3: a jittered 4 mm lattice and a jittered 3 mm one.
TetMesh coarse() {
  return fixtures::jittered(regular_lattice({4, 4, 4}, 4.0, Eigen::Vector3d::Zero()), 4.0, 0.2);
}
TetMesh fine() {
  return fixtures::jittered(regular_lattice({5, 5, 5}, 3.0, Eigen::Vector3d::Zero()), 3.0, 0.2);
}

TEST(FieldTransfer, WeightsSumToOneAndReproduceThePointInsideItsTet) {
  const TetMesh from = coarse();
  const TetMesh to = fine();
  const std::vector<TetPoint> located = locate_points(from, to.rest_mm);
  ASSERT_EQ(located.size(), static_cast<std::size_t>(to.vertex_count()));
  for (int v = 0; v < to.vertex_count(); ++v) {
    const TetPoint& p = located[v];
    double sum = 0.0;
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) {
      sum += p.weights[k];
      x += p.weights[k] * from.rest_mm.col(p.vertices[k]);
    }
    EXPECT_NEAR(sum, 1.0, 1e-12) << "vertex " << v;
    EXPECT_LT((x - to.rest_mm.col(v)).norm(), 1e-12) << "vertex " << v;
    // The jittered box's surface moves in and out, so a vertex of one mesh's surface may
    // lie just outside the other; inside, every weight is non-negative.
    const Eigen::Vector3d r = to.rest_mm.col(v);
    if ((r.array() > 1.0).all() && (r.array() < 11.0).all()) {
      for (int k = 0; k < 4; ++k) EXPECT_GE(p.weights[k], -1e-12) << "vertex " << v;
    }
  }
}

TEST(FieldTransfer, ALinearFieldComesThroughExactlyFromOneMeshToAnother) {
  const TetMesh from = coarse();
  const TetMesh to = fine();
  const Eigen::VectorXd moved =
      interpolate_vector_field(locate_points(from, to.rest_mm), linear_field(from.rest_mm));
  EXPECT_LT((moved - linear_field(to.rest_mm)).cwiseAbs().maxCoeff(), 1e-13);
}

TEST(FieldTransfer, APointOutsideTheMeshIsExtrapolatedFromTheTetNearest) {
  const TetMesh from = coarse();
  Eigen::Matrix3Xd outside(3, 2);
  outside.col(0) = Eigen::Vector3d(-0.5, 6.0, 6.0);
  outside.col(1) = Eigen::Vector3d(6.0, 6.0, 12.8);
  const std::vector<TetPoint> located = locate_points(from, outside);
  const Eigen::VectorXd moved = interpolate_vector_field(located, linear_field(from.rest_mm));
  EXPECT_LT((moved - linear_field(outside)).cwiseAbs().maxCoeff(), 1e-12);
  for (const TetPoint& p : located) {
    EXPECT_LT(*std::min_element(p.weights.begin(), p.weights.end()), 0.0);
    EXPECT_GT(*std::min_element(p.weights.begin(), p.weights.end()), -0.5);  // nearby tet
  }
}

TEST(FieldTransfer, TheSameMeshGivesEveryVertexItsOwnValue) {
  const TetMesh mesh = fine();
  Eigen::VectorXd field(3 * mesh.vertex_count());
  for (Eigen::Index i = 0; i < field.size(); ++i) field(i) = std::sin(0.37 * i);  // not linear
  const Eigen::VectorXd moved = interpolate_vector_field(locate_points(mesh, mesh.rest_mm), field);
  EXPECT_LT((moved - field).cwiseAbs().maxCoeff(), 1e-12);
}

}  // namespace
}  // namespace hapvox::engine::fem
