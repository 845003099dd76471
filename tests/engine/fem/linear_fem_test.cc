#include "engine/fem/linear_fem.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <chrono>
#include <cstdio>

#include "engine/errors.h"
#include "engine/fem/conforming_mesh.h"
#include "fem_fixtures.h"

namespace hapvox::engine::fem {
namespace {

using fixtures::axis_dofs;
using fixtures::vertices_where;

const Eigen::Vector3d kLinearFemOrigin(1.0, -2.0, 3.0);

// A box on the lattice with roller supports on its three low faces (each holds only its
// normal DOF), plus the top face's normal DOF, prescribed.
struct RollerBox {
  double h = 2.5;
  int nx = 4, ny = 3, nz = 6;
  TetMesh mesh = fixtures::jittered(regular_lattice({nx, ny, nz}, h, kLinearFemOrigin), h, 0.15);
  Eigen::Vector3d size() const { return h * Eigen::Vector3d(nx - 1, ny - 1, nz - 1); }
  std::vector<int> on_face(int axis, bool high) const {
    const double at = kLinearFemOrigin[axis] + (high ? size()[axis] : 0.0);
    return vertices_where(mesh,
                          [&](const Eigen::Vector3d& x) { return std::abs(x[axis] - at) < 1e-9; });
  }
  std::vector<int> constraints() const {
    std::vector<int> dofs;
    for (int axis = 0; axis < 3; ++axis) {
      for (int dof : axis_dofs(on_face(axis, false), axis)) dofs.push_back(dof);
    }
    for (int dof : axis_dofs(on_face(2, true), 2)) dofs.push_back(dof);
    return dofs;
  }
};

TEST(LinearFem, UniaxialCompressionMatchesHookesLaw) {
  const RollerBox box;
  const TetMaterial material{3e6, 0.3};
  const LinearFem fem(box.mesh, fixtures::uniform(box.mesh, material), box.constraints());
  const Eigen::Vector3d size = box.size();
  const double strain = 0.01, delta_mm = strain * size.z();
  Eigen::VectorXd prescribed = Eigen::VectorXd::Zero(3 * box.mesh.vertex_count());
  for (int v : box.on_face(2, true)) prescribed[dof_index(v, 2)] = -delta_mm;
  const Eigen::VectorXd loads = Eigen::VectorXd::Zero(prescribed.size());
  const Eigen::VectorXd u = fem.solve_mm(loads, prescribed);

  // Uniaxial stress: sigma_zz = -E strain, the other stresses zero, so the top face needs
  // F = E strain A (pressing down) and the sides expand by nu strain.
  const double force_n = material.youngs_pa * 1e-6 * strain * size.x() * size.y();
  const Eigen::VectorXd reactions = fem.reactions_n(u, loads);
  double top_n = 0, bottom_n = 0;
  for (int v : box.on_face(2, true)) top_n += reactions[dof_index(v, 2)];
  for (int v : box.on_face(2, false)) bottom_n += reactions[dof_index(v, 2)];
  EXPECT_NEAR(top_n / -force_n, 1.0, 1e-9);
  EXPECT_NEAR(bottom_n / force_n, 1.0, 1e-9);

  // Every vertex (interior ones jittered) follows the closed-form linear field.
  double worst = 0;
  for (int v = 0; v < box.mesh.vertex_count(); ++v) {
    const Eigen::Vector3d x = box.mesh.rest_mm.col(v) - kLinearFemOrigin;
    const Eigen::Vector3d expected(material.poisson * strain * x.x(),
                                   material.poisson * strain * x.y(), -strain * x.z());
    worst = std::max(worst, (u.segment<3>(3 * v) - expected).norm() / delta_mm);
  }
  EXPECT_LT(worst, 1e-9);
  const double lateral = u[dof_index(box.on_face(0, true).front(), 0)];
  EXPECT_NEAR(lateral / (material.poisson * strain * size.x()), 1.0, 1e-9);
  std::printf("[ measured ] uniaxial: force error %.2e, worst displacement error %.2e\n",
              std::abs(top_n / -force_n - 1), worst);
}

TEST(LinearFem, TwoLayersInSeriesAddTheirCompliances) {
  // Layers with equal nu/E expand sideways alike, so uniaxial stress holds exactly in both:
  // delta = sigma (h1/E1 + h2/E2).
  RollerBox box;
  box.mesh =
      regular_lattice({box.nx, box.ny, box.nz}, box.h, kLinearFemOrigin);  // a planar interface
  const double split = kLinearFemOrigin.z() + 2 * box.h;
  for (int t = 0; t < box.mesh.tet_count(); ++t) {
    double centroid_z = 0;
    for (int v : box.mesh.tets[t]) centroid_z += box.mesh.rest_mm(2, v) / 4;
    box.mesh.labels[t] = centroid_z < split ? 1 : 2;
  }
  const TetMaterial soft{1e6, 0.1}, hard{4e6, 0.4};
  const LinearFem fem(box.mesh, materials_from_labels(box.mesh, {{1, soft}, {2, hard}}),
                      box.constraints());
  const double delta_mm = 0.05;
  Eigen::VectorXd prescribed = Eigen::VectorXd::Zero(3 * box.mesh.vertex_count());
  for (int v : box.on_face(2, true)) prescribed[dof_index(v, 2)] = -delta_mm;
  const Eigen::VectorXd loads = Eigen::VectorXd::Zero(prescribed.size());
  const Eigen::VectorXd u = fem.solve_mm(loads, prescribed);
  const Eigen::VectorXd reactions = fem.reactions_n(u, loads);
  double top_n = 0;
  for (int v : box.on_face(2, true)) top_n += reactions[dof_index(v, 2)];
  const double h1 = 2 * box.h, h2 = box.size().z() - h1;
  const double stress_mpa =
      delta_mm / (h1 / (soft.youngs_pa * 1e-6) + h2 / (hard.youngs_pa * 1e-6));
  EXPECT_NEAR(top_n / (-stress_mpa * box.size().x() * box.size().y()), 1.0, 1e-9);
  // The interface moves by the soft layer's shortening.
  const int on_interface = vertices_where(box.mesh, [&](const Eigen::Vector3d& x) {
                             return std::abs(x.z() - split) < 1e-9;
                           }).front();
  EXPECT_NEAR(u[dof_index(on_interface, 2)] / (-stress_mpa * h1 / (soft.youngs_pa * 1e-6)), 1.0,
              1e-9);
}

TEST(LinearFem, PatchTestReproducesALinearFieldInsideAJitteredMesh) {
  const double h = 2.0;
  const TetMesh mesh = fixtures::jittered(regular_lattice({5, 5, 5}, h, kLinearFemOrigin), h, 0.2);
  ASSERT_EQ(mesh_quality(mesh).inverted_tets, 0);
  const Eigen::Vector3d lo = mesh.rest_mm.rowwise().minCoeff();
  const Eigen::Vector3d hi = mesh.rest_mm.rowwise().maxCoeff();
  const std::vector<int> surface = vertices_where(mesh, [&](const Eigen::Vector3d& x) {
    return ((x - lo).array().abs() < 1e-9).any() || ((x - hi).array().abs() < 1e-9).any();
  });
  const LinearFem fem(mesh, fixtures::uniform(mesh, {5e5, 0.35}), vertex_dofs(surface));
  ASSERT_EQ(fem.partition().free_count(), 3 * 27);  // the 3^3 interior vertices

  Eigen::Matrix3d gradient;  // stretch, shear and rotation at once
  gradient << 0.010, -0.004, 0.003, 0.006, -0.002, 0.005, -0.001, 0.007, 0.004;
  const Eigen::Vector3d offset(0.1, -0.2, 0.3);
  Eigen::VectorXd exact(3 * mesh.vertex_count());
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    exact.segment<3>(3 * v) = gradient * mesh.rest_mm.col(v) + offset;
  }
  const Eigen::VectorXd u = fem.solve_mm(Eigen::VectorXd::Zero(exact.size()), exact);
  double worst = 0;
  for (int dof : fem.partition().free_dofs()) {
    worst = std::max(worst, std::abs(u[dof] - exact[dof]));
  }
  EXPECT_LT(worst / exact.cwiseAbs().maxCoeff(), 1e-9);
  std::printf("[ measured ] patch test: worst interior error %.2e of the largest displacement\n",
              worst / exact.cwiseAbs().maxCoeff());
}

TEST(LinearFem, StiffnessIsSymmetricAndFreeOfRigidMotions) {
  const double h = 1.5;
  TetMesh mesh = fixtures::jittered(regular_lattice({4, 5, 3}, h, kLinearFemOrigin), h, 0.2);
  std::vector<TetMaterial> materials = fixtures::uniform(mesh, {2e6, 0.3});
  for (int t = 0; t < mesh.tet_count(); t += 3) materials[t] = {9e6, 0.1};
  const LinearFem fem(mesh, materials, vertex_dofs(std::vector<int>{0, 1, 4}));
  const Eigen::SparseMatrix<double>& k = fem.stiffness_n_per_mm();
  const Eigen::SparseMatrix<double> asymmetry = k - Eigen::SparseMatrix<double>(k.transpose());
  EXPECT_LT(asymmetry.norm(), 1e-14 * k.norm());
  // Translations and infinitesimal rotations strain nothing: K annihilates them.
  for (int mode = 0; mode < 6; ++mode) {
    Eigen::VectorXd u(3 * mesh.vertex_count());
    for (int v = 0; v < mesh.vertex_count(); ++v) {
      const Eigen::Vector3d axis = Eigen::Vector3d::Unit(mode % 3);
      u.segment<3>(3 * v) = mode < 3 ? axis : axis.cross(mesh.rest_mm.col(v)).eval();
    }
    EXPECT_LT((k * u).norm(), 1e-13 * k.norm() * u.norm()) << "mode " << mode;
  }
}

TEST(LinearFem, MaxwellBettiReciprocity) {
  const double h = 2.0;
  TetMesh mesh = fixtures::jittered(regular_lattice({6, 3, 4}, h, kLinearFemOrigin), h, 0.2);
  std::vector<TetMaterial> materials = fixtures::uniform(mesh, {2e6, 0.3});
  for (int t = 0; t < mesh.tet_count(); t += 4) materials[t] = {3e7, 0.45};
  const std::vector<int> clamped = vertices_where(
      mesh, [](const Eigen::Vector3d& x) { return std::abs(x.x() - kLinearFemOrigin.x()) < 1e-9; });
  const LinearFem fem(mesh, materials, vertex_dofs(clamped));
  const int i = dof_index(mesh.vertex_count() - 1, 2);  // a far corner, vertically
  const int j = dof_index(3 + 6 * (1 + 3 * 2), 0);      // vertex (3, 1, 2), along the beam
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(3 * mesh.vertex_count());
  Eigen::VectorXd load_i = zero, load_j = zero;
  load_i[i] = 0.7;
  load_j[j] = 0.7;
  const Eigen::VectorXd u_from_i = fem.solve_mm(load_i, zero);
  const Eigen::VectorXd u_from_j = fem.solve_mm(load_j, zero);
  // The work of load i on the displacements of load j equals the converse.
  ASSERT_GT(std::abs(u_from_i[j]), 1e-6);
  EXPECT_NEAR(u_from_j[i] / u_from_i[j], 1.0, 1e-9);
}

// A beam of length L = 10 h and square section h x h clamped at x = 0 and loaded by a
// uniform downward shear traction P on its tip face.
double cantilever_tip_deflection_mm(int cells_per_side, double* seconds = nullptr) {
  const double height_mm = 10, length_mm = 100, load_n = 0.5;
  const double h = height_mm / cells_per_side;
  const TetMesh mesh =
      regular_lattice({10 * cells_per_side + 1, cells_per_side + 1, cells_per_side + 1}, h,
                      Eigen::Vector3d::Zero());
  const auto start = std::chrono::steady_clock::now();
  const LinearFem fem(
      mesh, fixtures::uniform(mesh, {1e6, 0.3}),
      vertex_dofs(vertices_where(mesh, [](const Eigen::Vector3d& x) { return x.x() < 1e-9; })));
  // Consistent loads: each tip triangle carries its share of P, a third to each corner.
  Eigen::VectorXd loads = Eigen::VectorXd::Zero(3 * mesh.vertex_count());
  for (const Triangle& f : boundary_faces(mesh)) {
    const Eigen::Vector3d a = mesh.rest_mm.col(f[0]), b = mesh.rest_mm.col(f[1]),
                          c = mesh.rest_mm.col(f[2]);
    if (std::abs(a.x() - length_mm) + std::abs(b.x() - length_mm) + std::abs(c.x() - length_mm) >
        1e-9) {
      continue;
    }
    const double area = 0.5 * (b - a).cross(c - a).norm();
    for (int v : f) loads[dof_index(v, 2)] -= load_n * area / (height_mm * height_mm) / 3;
  }
  const Eigen::VectorXd u = fem.solve_mm(loads, Eigen::VectorXd::Zero(loads.size()));
  if (seconds != nullptr) {
    *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  // The deflection conjugate to the load: work / P.
  return loads.dot(u) / load_n;  // load and deflection both point down: positive work
}

TEST(LinearFem, CantileverDeflectionRisesUnderRefinementTowardEulerBernoulli) {
  // Euler-Bernoulli: delta = P L^3 / (3 E I), I = h^4 / 12 (E = 1 N/mm^2).
  const double euler_bernoulli_mm = 0.5 * 100.0 * 100 * 100 / (3 * 1.0 * 10.0 * 10 * 10 * 10 / 12);
  double previous = 0;
  for (int cells : {1, 2, 3, 4}) {
    double seconds = 0;
    const double deflection = cantilever_tip_deflection_mm(cells, &seconds);
    std::printf("[ measured ] cantilever %d cells per side: %.4f of Euler-Bernoulli (%.3f s)\n",
                cells, deflection / euler_bernoulli_mm, seconds);
    // A conforming displacement FEM is too stiff, and refining (nested: 1 -> 2 -> 4) can only
    // add compliance.
    EXPECT_GT(deflection, previous) << cells;
    EXPECT_LT(deflection, euler_bernoulli_mm) << cells;
    previous = deflection;
  }
  EXPECT_GT(previous, 0.5 * euler_bernoulli_mm);
}

TEST(LinearFem, TooFewConstraintsAreAnInputError) {
  const TetMesh mesh = regular_lattice({3, 3, 3}, 1.0, kLinearFemOrigin);
  const auto materials = fixtures::uniform(mesh, {1e6, 0.3});
  EXPECT_THROW(LinearFem(mesh, materials, {}), InputError);
  // Two pinned vertices leave the spin about the line through them.
  try {
    LinearFem(mesh, materials, vertex_dofs(std::vector<int>{0, 26}));
    FAIL() << "a free rotation was not caught";
  } catch (const InputError& error) {
    EXPECT_EQ(error.source(), "constraints");
  }
  EXPECT_NO_THROW(LinearFem(mesh, materials, vertex_dofs(std::vector<int>{0, 2, 6})));
  EXPECT_THROW(LinearFem(mesh, materials, std::vector<int>{3 * 27}), InputError);
}

TEST(LinearFem, BadMaterialNamesTheTet) {
  const TetMesh mesh = regular_lattice({3, 3, 3}, 1.0, kLinearFemOrigin);
  auto materials = fixtures::uniform(mesh, {1e6, 0.3});
  materials[9].poisson = 0.5;
  try {
    LinearFem(mesh, materials, vertex_dofs(std::vector<int>{0, 2, 6}));
    FAIL() << "nu = 0.5 was accepted";
  } catch (const InputError& error) {
    EXPECT_EQ(error.source(), "tet 9 (label 0)");
  }
}

// Volume-weighted mean of |strain| (Frobenius) over the tets labelled `label`.
double mean_strain(const LinearFem& fem, const Eigen::VectorXd& u, std::int32_t label) {
  double sum = 0, volume = 0;
  for (int t = 0; t < fem.mesh().tet_count(); ++t) {
    if (fem.mesh().labels[t] != label) continue;
    const TetShape& shape = fem.shape(t);
    Eigen::Matrix3d gradient = Eigen::Matrix3d::Zero();
    for (int a = 0; a < 4; ++a) {
      gradient +=
          u.segment<3>(3 * fem.mesh().tets[t][a]) * shape.gradients_per_mm.col(a).transpose();
    }
    sum += shape.volume_mm3 * (0.5 * (gradient + gradient.transpose())).norm();
    volume += shape.volume_mm3;
  }
  return sum / volume;
}

TEST(LinearFem, HardSphereInAConformingMeshBarelyStrainsUnderAPull) {
  // A first Fig. 5-like check: a sphere (label 1) in a soft cube (label 0), the left face
  // held, the right face pulled 1 % along x. For a stiff spherical inclusion Eshelby's
  // solution gives the inside strain as 1 / (1 + beta (E_in / E_out - 1)) of the far field,
  // beta = 2 (4 - 5 nu) / (15 (1 - nu)) = 0.476 for the shear part at nu = 0.3 (0.62 for
  // the volumetric part): about 2 % of the soft strain at 100x, 0.2 % at 1000x.
  const double side = 32, radius = 6;
  const Eigen::Vector3d center(16.1, 15.9, 16.2);
  const LabelFunction label = [&](const Eigen::Vector3d& x) -> std::int32_t {
    return (x - center).squaredNorm() < radius * radius ? 1 : 0;
  };
  ConformingMeshOptions options;
  options.box_mm = Eigen::AlignedBox3d(Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(side));
  options.coarse_spacing_mm = 4;
  options.boundary_levels = 1;
  const ConformingMesh built = build_conforming_mesh(options, label);
  const TetMesh& mesh = built.mesh;
  const Eigen::AlignedBox3d left(Eigen::Vector3d(-1, -1, -1),
                                 Eigen::Vector3d(0, side + 1, side + 1));
  const std::vector<VertexClass> classes = classify_vertices(mesh, {}, {left});
  std::vector<int> fixed, right;
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    if (classes[v] == VertexClass::kFixed) fixed.push_back(v);
    if (mesh.rest_mm(0, v) == side) right.push_back(v);
  }
  std::vector<int> constrained = vertex_dofs(fixed);
  for (int dof : axis_dofs(right, 0)) constrained.push_back(dof);
  const double pull_mm = 0.01 * side;
  Eigen::VectorXd prescribed = Eigen::VectorXd::Zero(3 * mesh.vertex_count());
  for (int v : right) prescribed[dof_index(v, 0)] = pull_mm;
  const Eigen::VectorXd no_loads = Eigen::VectorXd::Zero(prescribed.size());
  const TetMaterial soft{1e6, 0.3};
  for (const double contrast : {1.0, 100.0, 1000.0}) {
    const std::map<std::int32_t, TetMaterial> by_label = {{0, soft}, {1, {contrast * 1e6, 0.3}}};
    const LinearFem fem(mesh, materials_from_labels(mesh, by_label), constrained);
    const Eigen::VectorXd u = fem.solve_mm(no_loads, prescribed);
    const double ratio = mean_strain(fem, u, 1) / mean_strain(fem, u, 0);
    std::printf("E x%g: %d vertices, %d tets; hard/soft mean strain %.4f\n", contrast,
                mesh.vertex_count(), mesh.tet_count(), ratio);
    if (contrast == 1.0) {
      EXPECT_GT(ratio, 0.8);  // homogeneous: the sphere strains like the rest
    } else if (contrast == 100.0) {
      EXPECT_GT(ratio, 0.01);  // Eshelby: about 2 %, not 1 %
      EXPECT_LT(ratio, 0.03);
    } else {
      EXPECT_LE(ratio, 0.01);
    }
  }
}

}  // namespace
}  // namespace hapvox::engine::fem
