// Small strain per tet and per label (engine/fem/strain.h): exact for affine fields on a
// jittered mesh, zero for rigid motion, the equivalent strain's closed forms, and
// volume-weighted label means.

#include "engine/fem/strain.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "engine/errors.h"
#include "fem_fixtures.h"

namespace hapvox::engine::fem {
namespace {

// u = A x + b at every vertex.
Eigen::VectorXd affine_field(const TetMesh& mesh, const Eigen::Matrix3d& a,
                             const Eigen::Vector3d& b) {
  Eigen::VectorXd u(3 * mesh.vertex_count());
  for (int v = 0; v < mesh.vertex_count(); ++v) u.segment<3>(3 * v) = a * mesh.rest_mm.col(v) + b;
  return u;
}

TetMesh jittered_box() {
  return fixtures::jittered(regular_lattice({5, 4, 6}, 2.0, Eigen::Vector3d(1, -3, 2)), 2.0, 0.2);
}

TEST(Strain, AnAffineFieldGivesItsSymmetricGradientInEveryTet) {
  const TetMesh mesh = jittered_box();
  Eigen::Matrix3d a;
  a << 0.010, 0.004, -0.002,  //
      0.000, -0.003, 0.006,   //
      0.008, 0.001, 0.005;
  const Eigen::VectorXd u = affine_field(mesh, a, Eigen::Vector3d(3, -1, 2));
  const Eigen::Matrix3d expected = 0.5 * (a + a.transpose());
  for (int t = 0; t < mesh.tet_count(); ++t) {
    EXPECT_LT((tet_strain(mesh, t, u) - expected).norm(), 1e-14) << "tet " << t;
  }
}

TEST(Strain, ARigidInfinitesimalRotationAndTranslationGiveNone) {
  const TetMesh mesh = jittered_box();
  Eigen::Matrix3d spin;    // u = w x x: skew-symmetric gradient
  spin << 0, -0.03, 0.02,  //
      0.03, 0, -0.01,      //
      -0.02, 0.01, 0;
  const Eigen::VectorXd u = affine_field(mesh, spin, Eigen::Vector3d(5, 6, -7));
  for (int t = 0; t < mesh.tet_count(); ++t) {
    EXPECT_LT(strain_norm(tet_strain(mesh, t, u)), 1e-14) << "tet " << t;
  }
}

TEST(Strain, EquivalentStrainOfIsochoricUniaxialIsItsAxialStrainAndOfDilatationZero) {
  const double eps = 0.02;
  EXPECT_NEAR(equivalent_strain(Eigen::Vector3d(eps, -eps / 2, -eps / 2).asDiagonal()), eps, 1e-16);
  EXPECT_NEAR(equivalent_strain(Eigen::Vector3d(-eps, eps / 2, eps / 2).asDiagonal()), eps, 1e-16);
  EXPECT_NEAR(equivalent_strain(0.01 * Eigen::Matrix3d::Identity()), 0.0, 1e-18);
  // Pure shear gamma/2 off the diagonal: eps_eq = gamma / sqrt(3).
  Eigen::Matrix3d shear = Eigen::Matrix3d::Zero();
  shear(0, 1) = shear(1, 0) = 0.005;
  EXPECT_NEAR(equivalent_strain(shear), 0.01 / std::sqrt(3.0), 1e-16);
  EXPECT_NEAR(strain_norm(shear), 0.005 * std::sqrt(2.0), 1e-16);
}

TEST(Strain, LabelMeansAreVolumeWeightedAndSeparateLabels) {
  TetMesh mesh = jittered_box();
  // Label 1 on tets whose first vertex has x > 5, label 0 elsewhere. One affine field:
  // each label's mean is its strain, and the labels' volumes add up to the box.
  for (int t = 0; t < mesh.tet_count(); ++t) {
    mesh.labels[static_cast<std::size_t>(t)] =
        mesh.rest_mm(0, mesh.tets[static_cast<std::size_t>(t)][0]) > 5 ? 1 : 0;
  }
  const Eigen::Matrix3d a = Eigen::Vector3d(0.01, -0.005, -0.005).asDiagonal();
  const auto by_label = mean_strain_by_label(mesh, affine_field(mesh, a, Eigen::Vector3d::Zero()));
  ASSERT_EQ(by_label.size(), 2u);
  EXPECT_NEAR(by_label.at(0).volume_mm3 + by_label.at(1).volume_mm3,
              mesh_quality(mesh).total_volume_mm3, 1e-9);
  EXPECT_EQ(by_label.at(0).tet_count + by_label.at(1).tet_count, mesh.tet_count());
  for (const auto& [label, s] : by_label) {
    EXPECT_NEAR(s.mean_equivalent_strain, 0.01, 1e-14) << label;
    EXPECT_NEAR(s.mean_strain_norm, a.norm(), 1e-14) << label;
    EXPECT_NEAR(s.max_strain_norm, a.norm(), 1e-14) << label;
  }
  // Displacing only the face x = 9 (not jittered) strains label 1's tets next to it; label
  // 0's tets reach x = 7.4 at most (jitter 0.4 mm).
  Eigen::VectorXd u = Eigen::VectorXd::Zero(3 * mesh.vertex_count());
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    if (mesh.rest_mm(0, v) > 8) u(3 * v) = 0.1;
  }
  const auto local = mean_strain_by_label(mesh, u);
  EXPECT_GT(local.at(1).mean_strain_norm, 0.0);
  EXPECT_EQ(local.at(0).mean_strain_norm, 0.0);
}

TEST(Strain, AWrongSizedDisplacementIsAnInputError) {
  const TetMesh mesh = regular_lattice({2, 2, 2}, 1.0, Eigen::Vector3d::Zero());
  try {
    mean_strain_by_label(mesh, Eigen::VectorXd::Zero(5));
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "fem displacement: 5 values for 8 vertices (expected 3 per vertex)");
  }
}

}  // namespace
}  // namespace hapvox::engine::fem
