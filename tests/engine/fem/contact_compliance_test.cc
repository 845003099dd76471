#include "engine/fem/contact_compliance.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <numbers>

#include "alloc_counter.h"
#include "engine/errors.h"
#include "engine/fem/corotational.h"
#include "fem_fixtures.h"

// malloc counts too: fem_tests links with --wrap=malloc, so Eigen's heap temporaries in the
// library count as well as operator new.
extern "C" void* __real_malloc(std::size_t size);
extern "C" void* __wrap_malloc(std::size_t size) {
  ++hapvox::testing::allocations_on_this_thread;
  return __real_malloc(size);
}

namespace hapvox::engine::fem {
namespace {

using fixtures::vertices_where;
using ::hapvox::testing::allocations_on_this_thread;

const Eigen::Vector3d kComplianceOrigin(0.5, -1.0, 2.0);

// A jittered, two-material block standing on its clamped bottom face, and the vertices of
// its top face that are not on its edges (where a tool would press).
struct Block {
  double h = 2.0;
  TetMesh mesh = fixtures::jittered(regular_lattice({6, 5, 4}, h, kComplianceOrigin), h, 0.2);
  std::vector<TetMaterial> materials;
  std::vector<int> bottom, top;
  Block() {
    materials = fixtures::uniform(mesh, {2e6, 0.3});
    for (int t = 0; t < mesh.tet_count(); t += 5) materials[t] = {4e7, 0.45};
    bottom = vertices_where(mesh, [](const Eigen::Vector3d& x) {
      return std::abs(x.z() - kComplianceOrigin.z()) < 1e-9;
    });
    top = vertices_where(mesh, [this](const Eigen::Vector3d& x) {
      const Eigen::Vector3d local = (x - kComplianceOrigin) / h;
      return std::abs(local.z() - 3) < 1e-9 && local.x() > 0.5 && local.x() < 4.5 &&
             local.y() > 0.5 && local.y() < 3.5;
    });
  }
};

std::span<const double> view(const Eigen::VectorXd& v) { return {v.data(), std::size_t(v.size())}; }
std::span<double> view(Eigen::VectorXd& v) { return {v.data(), std::size_t(v.size())}; }

Eigen::VectorXd contact_displacements(int dofs) {
  Eigen::VectorXd u(dofs);
  for (int i = 0; i < dofs; ++i) u[i] = 0.01 * std::sin(1.7 * i + 0.3) - (i % 3 == 2 ? 0.05 : 0);
  return u;
}

TEST(ContactCompliance, ForcesEqualTheReactionsOfAFullSolve) {
  const Block block;
  ASSERT_EQ(block.top.size(), 12u);
  const LinearFem fem(block.mesh, block.materials, vertex_dofs(block.bottom));
  const ContactCompliance compliance(fem, block.top);
  const Eigen::VectorXd u_c = contact_displacements(compliance.dof_count());
  Eigen::VectorXd f_c(compliance.dof_count());
  ASSERT_TRUE(compliance.contact_forces_n(view(u_c), view(f_c)));

  // The same contact as Dirichlet conditions on the whole stiffness.
  std::vector<int> held = vertex_dofs(block.bottom);
  const std::vector<int> contact_dofs = vertex_dofs(block.top);
  held.insert(held.end(), contact_dofs.begin(), contact_dofs.end());
  const LinearFem full(block.mesh, block.materials, held);
  Eigen::VectorXd prescribed = Eigen::VectorXd::Zero(3 * block.mesh.vertex_count());
  for (std::size_t i = 0; i < contact_dofs.size(); ++i) prescribed[contact_dofs[i]] = u_c[i];
  const Eigen::VectorXd loads = Eigen::VectorXd::Zero(prescribed.size());
  const Eigen::VectorXd reactions = full.reactions_n(full.solve_mm(loads, prescribed), loads);
  Eigen::VectorXd expected(contact_dofs.size());
  for (std::size_t i = 0; i < contact_dofs.size(); ++i) expected[i] = reactions[contact_dofs[i]];
  const double error = fixtures::relative_error(f_c, expected);
  std::printf("[ measured ] condensed vs full reactions: %.2e relative\n", error);
  EXPECT_LT(error, 1e-9);

  // And back: those forces on the unconstrained contact give back u_c.
  Eigen::VectorXd contact_loads = loads;
  for (std::size_t i = 0; i < contact_dofs.size(); ++i) contact_loads[contact_dofs[i]] = f_c[i];
  const Eigen::VectorXd u = fem.solve_mm(contact_loads, loads);
  for (std::size_t i = 0; i < contact_dofs.size(); ++i) {
    EXPECT_NEAR(u[contact_dofs[i]], u_c[i], 1e-9 * u_c.norm());
  }
}

TEST(ContactCompliance, IsSymmetricPositiveDefinite) {
  const Block block;
  const LinearFem fem(block.mesh, block.materials, vertex_dofs(block.bottom));
  const ContactCompliance compliance(fem, block.top);
  const ContactCompliance::Matrix& w = compliance.compliance_mm_per_n();
  ASSERT_EQ(w.rows(), 36);
  EXPECT_LT((w - w.transpose()).norm(), 1e-12 * w.norm());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig{Eigen::MatrixXd(w)};
  std::printf("[ measured ] W eigenvalues %.3e .. %.3e mm/N\n", eig.eigenvalues().minCoeff(),
              eig.eigenvalues().maxCoeff());
  EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0);
}

TEST(ContactCompliance, PerTickForcesDoNotAllocate) {
  const Block block;
  const LinearFem fem(block.mesh, block.materials, vertex_dofs(block.bottom));
  std::vector<int> sixteen = block.top;
  for (int v : block.bottom) {
    if (sixteen.size() < 16) sixteen.push_back(v + 6 * 5);  // the free layer above
  }
  const ContactCompliance compliance(fem, sixteen);
  ASSERT_EQ(compliance.dof_count(), ContactCompliance::kMaxDofs);
  const Eigen::VectorXd u_c = contact_displacements(compliance.dof_count());
  std::array<double, ContactCompliance::kMaxDofs> f_c{};
  // Probe: the counter sees the library's Eigen heap use.
  const std::uint64_t probe = allocations_on_this_thread;
  const Eigen::VectorXd heap = fem.solve_free(Eigen::VectorXd::Ones(fem.partition().free_count()));
  ASSERT_GT(allocations_on_this_thread, probe) << "the allocation counter is blind";

  const int ticks = 20000;
  const std::uint64_t before = allocations_on_this_thread;
  const auto start = std::chrono::steady_clock::now();
  bool ok = true;
  for (int tick = 0; tick < ticks; ++tick) ok = compliance.contact_forces_n(view(u_c), f_c) && ok;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(allocations_on_this_thread, before);
  EXPECT_TRUE(ok);
  EXPECT_TRUE(std::isfinite(f_c[0]));
  std::printf("[ measured ] 1 kHz tick with 16 contact vertices: %.2f us\n", 1e6 * seconds / ticks);
}

TEST(ContactCompliance, FollowsARigidlyRotatedCorotationalBody) {
  const Block block;
  const CorotationalFem rest(block.mesh, block.materials, vertex_dofs(block.bottom));
  const ContactCompliance upright(rest.rest(), block.top);
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d(1, -1, 2).normalized())
          .toRotationMatrix();
  // Turn the whole block (its clamped base included) rigidly by 90 degrees.
  Eigen::VectorXd turned(3 * block.mesh.vertex_count());
  for (int v = 0; v < block.mesh.vertex_count(); ++v) {
    turned.segment<3>(3 * v) = (rotation - Eigen::Matrix3d::Identity()) * block.mesh.rest_mm.col(v);
  }
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(turned.size());
  for (int threshold : {1 << 30, 0}) {
    CorotationalFem fem(block.mesh, block.materials, vertex_dofs(block.bottom),
                        {.refactor_max_free_dofs = threshold});
    const Eigen::VectorXd u = fem.step_mm(turned, zero, turned);
    ASSERT_LT((u - turned).cwiseAbs().maxCoeff(), 1e-9);
    const ContactCompliance compliance(
        fem.rest().partition(), block.top,
        [&fem](const Eigen::VectorXd& rhs) { return fem.solve_free(rhs); });
    // A rotated body is as compliant as the upright one, along rotated directions:
    // W' = Q W Q^T with Q = diag(R, ..., R).
    ContactCompliance::Matrix expected = upright.compliance_mm_per_n();
    for (int a = 0; a < upright.vertex_count(); ++a) {
      for (int b = 0; b < upright.vertex_count(); ++b) {
        expected.block<3, 3>(3 * a, 3 * b) =
            rotation * upright.compliance_mm_per_n().block<3, 3>(3 * a, 3 * b) *
            rotation.transpose();
      }
    }
    EXPECT_LT((compliance.compliance_mm_per_n() - expected).norm(), 1e-9 * expected.norm())
        << (threshold == 0 ? "CG" : "refactorised");
  }
}

TEST(ContactCompliance, RejectsBadContactSets) {
  const Block block;
  const LinearFem fem(block.mesh, block.materials, vertex_dofs(block.bottom));
  EXPECT_THROW(ContactCompliance(fem, std::vector<int>{block.bottom[0]}), InputError);
  EXPECT_THROW(ContactCompliance(fem, std::vector<int>{block.top[0], block.top[0]}), InputError);
  EXPECT_THROW(ContactCompliance(fem, std::vector<int>{block.mesh.vertex_count()}), InputError);
  std::vector<int> seventeen;
  for (int v = 0; v < 17; ++v) seventeen.push_back(block.mesh.vertex_count() - 1 - v);
  EXPECT_THROW(ContactCompliance(fem, seventeen), InputError);
  const ContactCompliance compliance(fem, block.top);
  std::vector<double> u(35), f(36);
  EXPECT_FALSE(compliance.contact_forces_n(u, f));
}

}  // namespace
}  // namespace hapvox::engine::fem
