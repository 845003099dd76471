#include "engine/fem/corotational.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <chrono>
#include <cstdio>
#include <numbers>
#include <ostream>

#include "fem_fixtures.h"

namespace hapvox::engine::fem {
namespace {

using fixtures::vertices_where;

const Eigen::Vector3d kCorotationalOrigin(-1.0, 2.0, 0.5);

// The displacement that maps every vertex X to c + R (X + u(X) - c).
Eigen::VectorXd moved_by(const TetMesh& mesh, const Eigen::Matrix3d& rotation,
                         const Eigen::Vector3d& centre, const Eigen::VectorXd& u) {
  Eigen::VectorXd out(u.size());
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    const Eigen::Vector3d x = mesh.rest_mm.col(v);
    out.segment<3>(3 * v) = centre + rotation * (x + u.segment<3>(3 * v) - centre) - x;
  }
  return out;
}

Eigen::Matrix3Xd positions(const TetMesh& mesh, const Eigen::VectorXd& u) {
  return mesh.rest_mm + Eigen::Map<const Eigen::Matrix3Xd>(u.data(), 3, mesh.vertex_count());
}

std::vector<int> face_vertices(const TetMesh& mesh, int axis, double at) {
  return vertices_where(mesh,
                        [&](const Eigen::Vector3d& x) { return std::abs(x[axis] - at) < 1e-9; });
}

TEST(Corotational, RigidRotationBy90DegreesCostsNoForce) {
  const double h = 2.0;
  const TetMesh mesh =
      fixtures::jittered(regular_lattice({5, 5, 5}, h, kCorotationalOrigin), h, 0.2);
  const CorotationalFem fem(mesh, fixtures::uniform(mesh, {1e6, 0.3}),
                            vertex_dofs(face_vertices(mesh, 2, kCorotationalOrigin.z())));
  const Eigen::Vector3d centre = kCorotationalOrigin + Eigen::Vector3d(4, 4, 4);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(3 * mesh.vertex_count());
  // The yardstick: the elastic forces of a 1 % uniaxial strain along z.
  Eigen::VectorXd strained = zero;
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    strained[dof_index(v, 2)] = 0.01 * (mesh.rest_mm(2, v) - kCorotationalOrigin.z());
  }
  const double strain_force = fem.rest().elastic_forces_n(strained).norm();
  for (const Eigen::Vector3d& axis : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 2, -1)}) {
    const Eigen::Matrix3d rotation =
        Eigen::AngleAxisd(std::numbers::pi / 2, axis.normalized()).toRotationMatrix();
    const Eigen::VectorXd rotated = moved_by(mesh, rotation, centre, zero);
    const double corotational = fem.elastic_forces_n(rotated).norm() / strain_force;
    const double linear = fem.rest().elastic_forces_n(rotated).norm() / strain_force;
    std::printf(
        "[ measured ] 90 deg about (%g, %g, %g): co-rotational force %.2e, linear FEM's "
        "spurious force %.1f x that of a 1 %% strain\n",
        axis.x(), axis.y(), axis.z(), corotational, linear);
    EXPECT_LE(corotational, 1e-9);
    // Linear FEM reads R - I as a strain of order 1: about 100 times the 1 % one.
    EXPECT_GT(linear, 50.0);

    // Frame indifference: the strained body, rotated, pushes back with the rotated forces.
    const Eigen::VectorXd unrotated_forces = fem.rest().elastic_forces_n(strained);
    const Eigen::VectorXd forces = fem.elastic_forces_n(moved_by(mesh, rotation, centre, strained));
    Eigen::VectorXd expected(forces.size());
    for (int v = 0; v < mesh.vertex_count(); ++v) {
      expected.segment<3>(3 * v) = rotation * unrotated_forces.segment<3>(3 * v);
    }
    EXPECT_LT(fixtures::relative_error(forces, expected), 1e-12);
  }
}

TEST(Corotational, SmallDeformationsAgreeWithLinearFem) {
  const double h = 2.0;
  const TetMesh mesh =
      fixtures::jittered(regular_lattice({7, 3, 3}, h, kCorotationalOrigin), h, 0.2);
  CorotationalFem fem(mesh, fixtures::uniform(mesh, {1e6, 0.3}),
                      vertex_dofs(face_vertices(mesh, 0, kCorotationalOrigin.x())));
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(3 * mesh.vertex_count());
  // Relative difference between the two answers, and the tip's rotation, for a tip load.
  const auto compare = [&](double load_n) {
    Eigen::VectorXd loads = zero;
    for (int v : face_vertices(mesh, 0, kCorotationalOrigin.x() + 12))
      loads[dof_index(v, 2)] = -load_n;
    const Eigen::VectorXd linear = fem.rest().solve_mm(loads, zero);
    const Eigen::VectorXd corotational = fem.solve_mm(zero, loads, zero, 1e-16, 20);
    return std::pair(fixtures::relative_error(corotational, linear),
                     linear.cwiseAbs().maxCoeff() / 12);
  };
  const auto [difference, rotation] = compare(1e-5);
  const auto [tenth_difference, tenth_rotation] = compare(1e-6);
  std::printf("[ measured ] small loads: rotation %.1e rad -> difference %.1e; %.1e -> %.1e\n",
              rotation, difference, tenth_rotation, tenth_difference);
  // Co-rotation changes the answer by about the size of the rotations, so it vanishes
  // linearly with the load: linear FEM is its small-deformation limit.
  EXPECT_GT(rotation, 1e-5);
  EXPECT_LT(difference, 10 * rotation);
  EXPECT_NEAR(tenth_difference / difference, 0.1, 0.02);
}

struct Mode {
  const char* name;
  int refactor_max_free_dofs;
};

void PrintTo(const Mode& mode, std::ostream* out) { *out << mode.name; }

class CorotationalModes : public ::testing::TestWithParam<Mode> {};

TEST_P(CorotationalModes, RotatedCompressedBlockIsTheCompressedBlockRotated) {
  const double h = 2.0;
  const int nz = 7;
  const TetMesh mesh =
      fixtures::jittered(regular_lattice({4, 4, nz}, h, kCorotationalOrigin), h, 0.15);
  const double top = kCorotationalOrigin.z() + (nz - 1) * h;
  std::vector<int> clamped = face_vertices(mesh, 2, kCorotationalOrigin.z());
  for (int v : face_vertices(mesh, 2, top)) clamped.push_back(v);
  const TetMaterial material{1e6, 0.45};
  CorotationalFem fem(mesh, fixtures::uniform(mesh, material), vertex_dofs(clamped),
                      {.refactor_max_free_dofs = GetParam().refactor_max_free_dofs});
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(3 * mesh.vertex_count());
  const double rest_volume = mesh_quality(mesh).total_volume_mm3;

  // Squeeze the block by 2 % between its clamped ends.
  Eigen::VectorXd squeeze = zero;
  for (int v : face_vertices(mesh, 2, top))
    squeeze[dof_index(v, 2)] = -0.02 * (top - kCorotationalOrigin.z());
  int steps = 0;
  const Eigen::VectorXd upright = fem.solve_mm(zero, zero, squeeze, 1e-12, 50, &steps);
  const double upright_change =
      deformed_volume_mm3(mesh, positions(mesh, upright)) / rest_volume - 1;

  // Then turn the squeezed ends by 90 degrees about a horizontal axis, 15 degrees a step.
  const Eigen::Vector3d centre = kCorotationalOrigin + Eigen::Vector3d(3, 3, 6);
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 0.5, 0).normalized();
  Eigen::VectorXd u = upright;
  int total_steps = steps, max_cg = 0;
  for (int k = 1; k <= 6; ++k) {
    const Eigen::Matrix3d rotation =
        Eigen::AngleAxisd(k * std::numbers::pi / 12, axis).toRotationMatrix();
    const Eigen::VectorXd prescribed = moved_by(mesh, rotation, centre, upright);
    CorotationalStepReport report;
    for (int s = 0; s < 50; ++s) {
      const Eigen::VectorXd next = fem.step_mm(u, zero, prescribed, &report);
      ++total_steps;
      max_cg = std::max(max_cg, report.cg_iterations);
      EXPECT_LE(report.relative_residual, 1e-12);
      const double change = (next - u).cwiseAbs().maxCoeff();
      u = next;
      if (change < 1e-12) break;
    }
  }
  const Eigen::Matrix3d quarter = Eigen::AngleAxisd(std::numbers::pi / 2, axis).toRotationMatrix();
  const Eigen::VectorXd expected = moved_by(mesh, quarter, centre, upright);
  const double mismatch = (u - expected).cwiseAbs().maxCoeff();
  const double volume_change = deformed_volume_mm3(mesh, positions(mesh, u)) / rest_volume - 1;
  const Eigen::VectorXd linear = fem.rest().solve_mm(zero, expected);
  const double linear_change = deformed_volume_mm3(mesh, positions(mesh, linear)) / rest_volume - 1;
  std::printf(
      "[ measured ] %s: %d steps (max %d CG iterations); rotated vs upright %.1e mm; volume "
      "change %.3f %% (upright %.3f %%); linear FEM %.1f %%\n",
      GetParam().name, total_steps, max_cg, mismatch, 100 * volume_change, 100 * upright_change,
      100 * linear_change);
  // Co-rotational FEM is frame indifferent: turning the ends turns the whole solution.
  EXPECT_LT(mismatch, 1e-9);
  // A 2 % squeeze of a nearly incompressible block (nu = 0.45) changes its volume by about
  // (1 - 2 nu) 2 % = 0.2 %, whichever way it faces; linear FEM loses that under rotation.
  EXPECT_LT(std::abs(volume_change), 0.01);
  EXPECT_NEAR(volume_change, upright_change, 1e-9);
  EXPECT_GT(std::abs(linear_change), 0.05);
}

INSTANTIATE_TEST_SUITE_P(Solvers, CorotationalModes,
                         ::testing::Values(Mode{"refactorised", 1 << 30},
                                           Mode{"preconditioned CG", 0}),
                         [](const auto& info) {
                           return std::string(info.param.refactor_max_free_dofs == 0
                                                  ? "ConjugateGradients"
                                                  : "Refactorised");
                         });

TEST(Corotational, ReportsStepTimesAtAThousandTets) {
  const double h = 2.0;
  const TetMesh mesh = regular_lattice({7, 7, 7}, h, kCorotationalOrigin);  // 1,296 tets
  const std::vector<int> clamped = face_vertices(mesh, 2, kCorotationalOrigin.z());
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(3 * mesh.vertex_count());
  Eigen::VectorXd loads = zero;
  for (int v : face_vertices(mesh, 2, kCorotationalOrigin.z() + 12)) loads[dof_index(v, 0)] = 0.02;
  using Clock = std::chrono::steady_clock;
  const auto ms = [](Clock::duration d) {
    return std::chrono::duration<double, std::milli>(d).count();
  };
  for (int threshold : {1 << 30, 0}) {
    const auto built = Clock::now();
    CorotationalFem fem(mesh, fixtures::uniform(mesh, {1e6, 0.3}), vertex_dofs(clamped),
                        {.refactor_max_free_dofs = threshold});
    const auto factored = Clock::now();
    Eigen::VectorXd u = fem.rest().solve_mm(loads, zero);
    const auto linear = Clock::now();
    CorotationalStepReport report;
    const int steps = 5;
    for (int s = 0; s < steps; ++s) u = fem.step_mm(u, loads, zero, &report);
    const auto done = Clock::now();
    std::printf(
        "[ measured ] %d tets, %s: build + factor %.1f ms, linear solve %.2f ms, co-rotational "
        "step %.2f ms (%d CG iterations)\n",
        mesh.tet_count(), threshold == 0 ? "CG" : "refactorised", ms(factored - built),
        ms(linear - factored), ms(done - linear) / steps, report.cg_iterations);
    EXPECT_TRUE(u.allFinite());
  }
}

}  // namespace
}  // namespace hapvox::engine::fem
