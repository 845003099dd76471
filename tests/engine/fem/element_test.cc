#include "engine/fem/element.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <cmath>

#include "engine/errors.h"

namespace hapvox::engine::fem {
namespace {

// A deliberately irregular tet (mm).
const Eigen::Vector3d kX[4] = {{0.1, 0.2, -0.3}, {2.0, 0.1, 0.4}, {0.5, 1.7, 0.2}, {0.3, 0.4, 2.2}};
const TetMaterial kMaterial{2.5e6, 0.3};

struct Element {
  Eigen::Matrix<double, 3, 4> g = barycentric_gradients_per_mm(kX[0], kX[1], kX[2], kX[3]);
  double volume_mm3 = signed_volume_mm3(kX[0], kX[1], kX[2], kX[3]);
  ElementMatrix k = element_stiffness_n_per_mm(g, volume_mm3, kMaterial);
};

// The nodal displacements of the field u(x) = grad_u x + offset.
Eigen::Matrix<double, 12, 1> linear_field(const Eigen::Matrix3d& grad_u,
                                          const Eigen::Vector3d& offset) {
  Eigen::Matrix<double, 12, 1> u;
  for (int a = 0; a < 4; ++a) u.segment<3>(3 * a) = grad_u * kX[a] + offset;
  return u;
}

// Nodal forces of a constant stress (N/mm^2 = MPa): f_a = V sigma g_a (virtual work).
Eigen::Matrix<double, 12, 1> stress_forces(const Element& e, const Eigen::Matrix3d& stress) {
  Eigen::Matrix<double, 12, 1> f;
  for (int a = 0; a < 4; ++a) f.segment<3>(3 * a) = e.volume_mm3 * stress * e.g.col(a);
  return f;
}

TEST(ElementStiffness, UniaxialStressGivesEStrainAlongTheAxisOnly) {
  const Element e;
  const double s = 1e-3;
  // Uniaxial stress along x: eps = diag(s, -nu s, -nu s) gives sigma = diag(E s, 0, 0).
  const Eigen::Matrix3d strain =
      Eigen::Vector3d(s, -kMaterial.poisson * s, -kMaterial.poisson * s).asDiagonal();
  const Eigen::Matrix<double, 12, 1> f = e.k * linear_field(strain, Eigen::Vector3d(1, 2, 3));
  Eigen::Matrix3d stress = Eigen::Matrix3d::Zero();
  stress(0, 0) = kMaterial.youngs_pa * 1e-6 * s;
  const Eigen::Matrix<double, 12, 1> expected = stress_forces(e, stress);
  EXPECT_LT((f - expected).norm(), 1e-12 * expected.norm()) << f.transpose();
}

TEST(ElementStiffness, SimpleShearGivesTheShearModulus) {
  const Element e;
  const double gamma = 2e-3;
  Eigen::Matrix3d grad_u = Eigen::Matrix3d::Zero();
  grad_u(0, 1) = gamma;  // u_x = gamma y: engineering shear strain gamma in xy
  const double shear_modulus = kMaterial.youngs_pa * 1e-6 / (2 * (1 + kMaterial.poisson));
  Eigen::Matrix3d stress = Eigen::Matrix3d::Zero();
  stress(0, 1) = stress(1, 0) = shear_modulus * gamma;
  const Eigen::Matrix<double, 12, 1> expected = stress_forces(e, stress);
  const Eigen::Matrix<double, 12, 1> f = e.k * linear_field(grad_u, Eigen::Vector3d::Zero());
  EXPECT_LT((f - expected).norm(), 1e-12 * expected.norm());
  // Strain energy (1/2) u.K u = (1/2) V sigma:eps.
  const Eigen::Matrix<double, 12, 1> u = linear_field(grad_u, Eigen::Vector3d::Zero());
  EXPECT_NEAR(0.5 * u.dot(e.k * u) / (0.5 * e.volume_mm3 * shear_modulus * gamma * gamma), 1.0,
              1e-12);
}

TEST(ElementStiffness, RigidMotionsCostNoForce) {
  const Element e;
  Eigen::Matrix3d spin;  // an infinitesimal rotation: antisymmetric gradient
  spin << 0, -0.3, 0.2, 0.3, 0, -0.1, -0.2, 0.1, 0;
  const Eigen::Matrix<double, 12, 1> u = linear_field(1e-3 * spin, Eigen::Vector3d(4, -5, 6));
  EXPECT_LT((e.k * u).norm(), 1e-13 * e.k.norm() * u.norm());
}

TEST(ElementStiffness, IsSymmetricPositiveSemidefiniteWithSixRigidModes) {
  const Element e;
  EXPECT_LT((e.k - e.k.transpose()).norm(), 1e-15 * e.k.norm());
  const Eigen::SelfAdjointEigenSolver<ElementMatrix> eig(e.k);
  const auto& values = eig.eigenvalues();  // ascending
  for (int i = 0; i < 6; ++i) EXPECT_LT(std::abs(values[i]), 1e-12 * values[11]) << i;
  EXPECT_GT(values[6], 1e-3 * values[11]);
}

TEST(Materials, RejectBadModuliNamingTetAndLabel) {
  TetMesh mesh = regular_lattice({2, 2, 2}, 1.0, Eigen::Vector3d::Zero(), 7);
  std::vector<TetMaterial> materials(mesh.tets.size(), kMaterial);
  EXPECT_NO_THROW(validate_materials(mesh, materials));
  const auto rejects = [&](TetMaterial bad) {
    materials[4] = bad;
    try {
      validate_materials(mesh, materials);
      return false;
    } catch (const InputError& error) {
      EXPECT_EQ(error.source(), "tet 4 (label 7)");
      return true;
    }
  };
  EXPECT_TRUE(rejects({0.0, 0.3}));
  EXPECT_TRUE(rejects({-1e6, 0.3}));
  EXPECT_TRUE(rejects({std::nan(""), 0.3}));
  EXPECT_TRUE(rejects({1e6, 0.5}));
  EXPECT_TRUE(rejects({1e6, -1.0}));
  EXPECT_TRUE(rejects({1e6, std::nan("")}));
  EXPECT_FALSE(rejects({1e6, 0.499}));
  EXPECT_FALSE(rejects({1e6, -0.99}));
  materials.pop_back();
  EXPECT_THROW(validate_materials(mesh, materials), InputError);
}

TEST(Materials, ComeFromLabelsAndAMissingLabelIsNamed) {
  TetMesh mesh = regular_lattice({2, 2, 3}, 1.0, Eigen::Vector3d::Zero(), 1);
  for (int t = 6; t < 12; ++t) mesh.labels[t] = 2;
  const auto materials = materials_from_labels(mesh, {{1, {1e6, 0.3}}, {2, {5e6, 0.2}}});
  EXPECT_EQ(materials[0].youngs_pa, 1e6);
  EXPECT_EQ(materials[11].youngs_pa, 5e6);
  try {
    materials_from_labels(mesh, {{1, {1e6, 0.3}}});
    FAIL() << "label 2 has no material";
  } catch (const InputError& error) {
    EXPECT_EQ(error.source(), "label 2");
  }
  EXPECT_THROW(materials_from_labels(mesh, {{1, {1e6, 0.3}}, {2, {-5, 0.2}}}), InputError);
}

}  // namespace
}  // namespace hapvox::engine::fem
