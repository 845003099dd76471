#include "render/gradient_rotation.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <random>

#include "engine/errors.h"

namespace hapvox::render {
namespace {

using engine::fem::TetMesh;

// A 5 x 4 x 4 lattice with every interior vertex jittered, so frames are not axis-aligned.
TetMesh jittered_mesh() {
  TetMesh mesh = engine::fem::regular_lattice({5, 4, 4}, 2.0, Eigen::Vector3d(1, -2, 3));
  std::mt19937 random(7);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    for (int a = 0; a < 3; ++a) mesh.rest_mm(a, v) += jitter(random);
  }
  return mesh;
}

Eigen::VectorXd displacement_of(const TetMesh& mesh, const Eigen::Matrix3d& a,
                                const Eigen::Vector3d& b) {
  Eigen::VectorXd u(3 * mesh.vertex_count());
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    u.segment<3>(3 * v) = a * mesh.rest_mm.col(v) + b - mesh.rest_mm.col(v);
  }
  return u;
}

TEST(GradientRotation, GramSchmidtFrameIsARightHandedOrthonormalBasisAlongTheFirstEdge) {
  const Eigen::Vector3d e1(2, 1, -1), e2(0.5, 3, 1);
  const Eigen::Matrix3d n = gram_schmidt_frame(e1, e2);
  EXPECT_LT((n.transpose() * n - Eigen::Matrix3d::Identity()).norm(), 1e-15);
  EXPECT_NEAR(n.determinant(), 1.0, 1e-15);
  EXPECT_LT((n.col(0) - e1.normalized()).norm(), 1e-15);
  EXPECT_NEAR(n.col(2).dot(e2), 0.0, 1e-14);  // e2 lies in the plane of n1 and n2
  EXPECT_GT(n.col(1).dot(e2), 0.0);
}

TEST(GradientRotation, EveryVertexRotationIsTheAppliedRotationOfARigidMotion) {
  const TetMesh mesh = jittered_mesh();
  const Eigen::Matrix3d r =
      Eigen::AngleAxisd(1.1, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  const Eigen::VectorXd u = displacement_of(mesh, r, Eigen::Vector3d(4, -7, 2.5));
  const auto neighbours = frame_neighbours(mesh);
  double worst = 0.0;
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    ASSERT_GE(neighbours[v][0], 0);
    worst = std::max(worst, (vertex_rotation(mesh, neighbours[v], v, u) - r).norm());
  }
  EXPECT_LT(worst, 1e-12);
  // F^-T of a rotation is the rotation.
  for (int t = 0; t < mesh.tet_count(); ++t) {
    ASSERT_LT((tet_inverse_transpose(mesh, t, u) - r).norm(), 1e-12) << "tet " << t;
  }
}

TEST(GradientRotation, InverseTransposeIsExactForAnAffineMapAndRotationIsNot) {
  const TetMesh mesh = jittered_mesh();
  Eigen::Matrix3d a;
  a << 1.2, 0.3, 0.0, -0.1, 0.9, 0.2, 0.05, 0.0, 1.1;
  const Eigen::VectorXd u = displacement_of(mesh, a, Eigen::Vector3d(1, 2, 3));
  const Eigen::Matrix3d expected = a.inverse().transpose();
  for (int t = 0; t < mesh.tet_count(); ++t) {
    ASSERT_LT((tet_inverse_transpose(mesh, t, u) - expected).norm(), 1e-12) << "tet " << t;
  }
  // R = N'N^T keeps only a rotation: orthogonal, and not A^-T under shear.
  const auto neighbours = frame_neighbours(mesh);
  const Eigen::Matrix3d r = vertex_rotation(mesh, neighbours[0], 0, u);
  EXPECT_LT((r.transpose() * r - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_GT((r - expected).norm(), 0.05);
}

TEST(GradientRotation, NoDisplacementGivesTheIdentity) {
  const TetMesh mesh = jittered_mesh();
  const Eigen::VectorXd u = Eigen::VectorXd::Zero(3 * mesh.vertex_count());
  const auto neighbours = frame_neighbours(mesh);
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    ASSERT_LT((vertex_rotation(mesh, neighbours[v], v, u) - Eigen::Matrix3d::Identity()).norm(),
              1e-14);
  }
}

TEST(GradientRotation, NamesRoundTripAndAnUnknownOneIsRefused) {
  for (GradientTransform g :
       {GradientTransform::kVertexRotation, GradientTransform::kTetInverseTranspose}) {
    EXPECT_EQ(parse_gradient_transform(gradient_transform_name(g), "flag"), g);
  }
  try {
    parse_gradient_transform("polar", "--gradient");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "--gradient: unknown gradient transform 'polar' (rotation or inverse-transpose)");
  }
}

}  // namespace
}  // namespace hapvox::render
