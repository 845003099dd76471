#include "engine/fem/rotations.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <numbers>

namespace hapvox::engine::fem {
namespace {

const Eigen::Matrix3d kRotation =
    Eigen::AngleAxisd(2.1, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();

TEST(PolarRotation, RecoversTheRotationOfARotatedStretch) {
  Eigen::Matrix3d stretch;  // symmetric positive definite
  stretch << 1.2, 0.1, -0.05, 0.1, 0.9, 0.2, -0.05, 0.2, 1.1;
  EXPECT_LT((polar_rotation(kRotation * stretch) - kRotation).norm(), 1e-14);
  EXPECT_LT((polar_rotation(kRotation) - kRotation).norm(), 1e-15);
}

TEST(PolarRotation, IsAProperRotationForAnInvertedTet) {
  const Eigen::Matrix3d mirrored = kRotation * Eigen::Vector3d(1.0, 0.8, -0.3).asDiagonal();
  const Eigen::Matrix3d r = polar_rotation(mirrored);
  EXPECT_LT((r.transpose() * r - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_NEAR(r.determinant(), 1.0, 1e-14);
  // Q diag(1, 0.8, -0.3) is Q times a reflection of its least stretched axis: the nearest
  // rotation undoes that reflection and is Q itself.
  EXPECT_LT((r - kRotation).norm(), 1e-13);
}

TEST(DeformationGradient, IsTheMapOfTheRestEdges) {
  const Eigen::Vector3d x[4] = {{0, 0, 0}, {1.5, 0.1, 0}, {0.2, 1.1, 0.1}, {0.3, -0.2, 0.9}};
  const Eigen::Matrix<double, 3, 4> g = barycentric_gradients_per_mm(x[0], x[1], x[2], x[3]);
  Eigen::Matrix3d f;
  f << 1.1, 0.2, -0.3, 0.05, 0.95, 0.1, 0.0, -0.2, 1.3;
  ElementVector u;
  for (int a = 0; a < 4; ++a) u.segment<3>(3 * a) = f * x[a] - x[a] + Eigen::Vector3d(1, 2, 3);
  EXPECT_LT((deformation_gradient(g, u) - f).norm(), 1e-14);
}

TEST(VertexRotations, AverageTheTetsAround) {
  const TetMesh mesh = regular_lattice({2, 2, 2}, 1.0, Eigen::Vector3d::Zero());
  std::vector<Eigen::Matrix3d> tets(mesh.tets.size(), kRotation);
  const std::vector<double> volumes(mesh.tets.size(), 1.0 / 6);
  for (const Eigen::Matrix3d& r : vertex_rotations(mesh, tets, volumes)) {
    EXPECT_LT((r - kRotation).norm(), 1e-14);
  }
  // Two equal-weight rotations about one axis by +-a average to the identity.
  const Eigen::Matrix3d plus = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d minus = plus.transpose();
  for (int t = 0; t < 6; ++t) tets[t] = t % 2 == 0 ? plus : minus;
  // Vertex 0 and 7 belong to all six tets.
  EXPECT_LT((vertex_rotations(mesh, tets, volumes)[0] - Eigen::Matrix3d::Identity()).norm(), 1e-14);
}

}  // namespace
}  // namespace hapvox::engine::fem
