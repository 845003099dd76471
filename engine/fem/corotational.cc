#include "engine/fem/corotational.h"

#include <cmath>

#include "engine/check.h"
#include "engine/errors.h"
#include "engine/fem/rotations.h"

namespace hapvox::engine::fem {

CorotationalFem::CorotationalFem(TetMesh mesh, std::span<const TetMaterial> materials,
                                 std::span<const int> constrained_dofs, CorotationalOptions options)
    : rest_(std::move(mesh), materials, constrained_dofs),
      options_(options),
      rotations_(rest_.mesh().tets.size(), Eigen::Matrix3d::Identity()) {
  const TetMesh& m = rest_.mesh();
  const DofPartition& partition = rest_.partition();
  tet_volumes_mm3_.reserve(m.tets.size());
  for (int t = 0; t < m.tet_count(); ++t) tet_volumes_mm3_.push_back(rest_.shape(t).volume_mm3);
  free_vertex_start_.assign(m.vertex_count(), -1);
  for (int v = 0; v < m.vertex_count(); ++v) {
    if (partition.is_free(dof_index(v, 0)) && partition.is_free(dof_index(v, 1)) &&
        partition.is_free(dof_index(v, 2))) {
      free_vertex_start_[v] = partition.free_index(dof_index(v, 0));
    }
  }
  vertex_rotations_.assign(m.vertex_count(), Eigen::Matrix3d::Identity());
  warped_ff_ = rest_.assembler().zero_matrix();
  // The warped matrix keeps K_FF's pattern: order and symbolic factor once.
  if (partition.free_count() <= options_.refactor_max_free_dofs) {
    warped_ldlt_.analyzePattern(warped_ff_);
  }
}

std::vector<Eigen::Matrix3d> CorotationalFem::rotations_of(const Eigen::VectorXd& displacement_mm,
                                                           int* inverted_tets) const {
  HAPVOX_CHECK_EQ(displacement_mm.size(), rest_.partition().dof_count());
  const TetMesh& m = rest_.mesh();
  std::vector<Eigen::Matrix3d> rotations;
  rotations.reserve(m.tets.size());
  int inverted = 0;
  for (int t = 0; t < m.tet_count(); ++t) {
    const Eigen::Matrix3d f =
        deformation_gradient(rest_.shape(t).gradients_per_mm, gather(m.tets[t], displacement_mm));
    if (f.determinant() <= 0.0) ++inverted;
    rotations.push_back(polar_rotation(f));
  }
  if (inverted_tets != nullptr) *inverted_tets = inverted;
  return rotations;
}

void CorotationalFem::set_tangent(std::vector<Eigen::Matrix3d> rotations) {
  rotations_ = std::move(rotations);
  rest_.assembler().assemble([this](int t) { return warped(t); }, warped_ff_);
  stepped_ = true;
  use_warped_factor_ = rest_.partition().free_count() <= options_.refactor_max_free_dofs;
  if (use_warped_factor_) {
    warped_ldlt_.factorize(warped_ff_);
    check_positive_definite(warped_ldlt_);
  } else {
    vertex_rotations_ = vertex_rotations(rest_.mesh(), rotations_, tet_volumes_mm3_);
  }
}

ElementMatrix CorotationalFem::warped(int tet) const {
  const Eigen::Matrix3d& r = rotations_[tet];
  const ElementMatrix& k = rest_.element_stiffness(tet);
  ElementMatrix out;
  for (int a = 0; a < 4; ++a) {
    for (int b = 0; b < 4; ++b) {
      out.block<3, 3>(3 * a, 3 * b) = r * k.block<3, 3>(3 * a, 3 * b) * r.transpose();
    }
  }
  return out;
}

Eigen::VectorXd CorotationalFem::forces_n(const std::vector<Eigen::Matrix3d>& rotations,
                                          const Eigen::VectorXd& displacement_mm,
                                          double* energy_nmm) const {
  const TetMesh& m = rest_.mesh();
  Eigen::VectorXd forces = Eigen::VectorXd::Zero(displacement_mm.size());
  double energy = 0.0;
  for (int t = 0; t < m.tet_count(); ++t) {
    const Tet& tet = m.tets[t];
    const Eigen::Matrix3d& r = rotations[t];
    const ElementVector u = gather(tet, displacement_mm);
    // Positions relative to vertex 0: K_e ignores the common translation, and small
    // numbers keep R^T x - X exact to round-off for a rigid motion.
    ElementVector unrotated;
    for (int a = 0; a < 4; ++a) {
      const Eigen::Vector3d rest_edge = m.rest_mm.col(tet[a]) - m.rest_mm.col(tet[0]);
      const Eigen::Vector3d edge = rest_edge + u.segment<3>(3 * a) - u.segment<3>(0);
      unrotated.segment<3>(3 * a) = r.transpose() * edge - rest_edge;
    }
    ElementVector f = rest_.element_stiffness(t) * unrotated;
    if (energy_nmm != nullptr) energy += 0.5 * unrotated.dot(f);
    for (int a = 0; a < 4; ++a) f.segment<3>(3 * a) = r * f.segment<3>(3 * a).eval();
    scatter_add(tet, f, forces);
  }
  if (energy_nmm != nullptr) *energy_nmm = energy;
  return forces;
}

Eigen::VectorXd CorotationalFem::elastic_forces_n(const Eigen::VectorXd& displacement_mm) const {
  return forces_n(rotations_of(displacement_mm), displacement_mm);
}

Eigen::VectorXd CorotationalFem::step_mm(const Eigen::VectorXd& guess_mm,
                                         const Eigen::VectorXd& loads_n,
                                         const Eigen::VectorXd& prescribed_mm,
                                         CorotationalStepReport* report) {
  const DofPartition& partition = rest_.partition();
  const int n = partition.dof_count();
  if (loads_n.size() != n || prescribed_mm.size() != n || guess_mm.size() != n) {
    throw InputError("FEM step", "guess, loads and prescribed displacements need " +
                                     std::to_string(n) + " entries each");
  }
  set_tangent(rotations_of(guess_mm));
  tangent_at_mm_ = guess_mm;

  // With the rotations frozen the forces are affine in u: for u = u_C + u_F (prescribed
  // part plus free part), K_R,FF u_F = f_F - forces(u_C)_F.
  Eigen::VectorXd u = partition.constrained_only(prescribed_mm);
  const Eigen::VectorXd rhs =
      partition.free_part(loads_n) - partition.free_part(forces_n(rotations_, u));
  CorotationalStepReport local;
  Eigen::VectorXd u_free;
  if (use_warped_factor_) {
    u_free = warped_ldlt_.solve(rhs);
    local.refactorised = true;
  } else {
    u_free = partition.free_part(guess_mm);  // warm start
    conjugate_gradients(rhs, u_free, local);
  }
  partition.add_free_part(u_free, u);
  if (report != nullptr) *report = local;
  return u;
}

Eigen::VectorXd CorotationalFem::solve_mm(const Eigen::VectorXd& guess_mm,
                                          const Eigen::VectorXd& loads_n,
                                          const Eigen::VectorXd& prescribed_mm, double tolerance_mm,
                                          int max_steps, int* steps_taken) {
  Eigen::VectorXd u = guess_mm;
  int steps = 0;
  while (steps < max_steps) {
    Eigen::VectorXd next = step_mm(u, loads_n, prescribed_mm);
    ++steps;
    const double change = (next - u).cwiseAbs().maxCoeff();
    u = std::move(next);
    if (change <= tolerance_mm) break;
  }
  if (steps_taken != nullptr) *steps_taken = steps;
  return u;
}

Eigen::VectorXd CorotationalFem::solve_free(const Eigen::VectorXd& rhs_free) const {
  HAPVOX_CHECK_EQ(rhs_free.size(), rest_.partition().free_count());
  if (!stepped_) return rest_.solve_free(rhs_free);
  if (use_warped_factor_) return warped_ldlt_.solve(rhs_free);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(rhs_free.size());
  CorotationalStepReport report;
  conjugate_gradients(rhs_free, x, report);
  return x;
}

Eigen::VectorXd CorotationalFem::precondition(const Eigen::VectorXd& residual) const {
  // K_R ~ Q K Q^T for vertex rotations Q, so K_R^-1 ~ Q K^-1 Q^T. Vertices with a
  // constrained DOF keep the identity: S stays orthogonal and the preconditioner SPD.
  Eigen::VectorXd rotated = residual;
  for (std::size_t v = 0; v < free_vertex_start_.size(); ++v) {
    const int f = free_vertex_start_[v];
    if (f >= 0) rotated.segment<3>(f) = vertex_rotations_[v].transpose() * residual.segment<3>(f);
  }
  Eigen::VectorXd z = rest_.solve_free(rotated);
  for (std::size_t v = 0; v < free_vertex_start_.size(); ++v) {
    const int f = free_vertex_start_[v];
    if (f >= 0) z.segment<3>(f) = (vertex_rotations_[v] * z.segment<3>(f)).eval();
  }
  return z;
}

void CorotationalFem::conjugate_gradients(const Eigen::VectorXd& rhs, Eigen::VectorXd& x,
                                          CorotationalStepReport& report) const {
  const double rhs_norm = rhs.norm();
  if (rhs_norm == 0) {
    x.setZero();
    return;
  }
  Eigen::VectorXd r = rhs - warped_ff_ * x;
  Eigen::VectorXd z = precondition(r);
  Eigen::VectorXd p = z;
  double rz = r.dot(z);
  int iteration = 0;
  while (r.norm() > options_.cg_relative_residual * rhs_norm &&
         iteration < options_.cg_max_iterations) {
    const Eigen::VectorXd kp = warped_ff_ * p;
    const double alpha = rz / p.dot(kp);
    x += alpha * p;
    r -= alpha * kp;
    z = precondition(r);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
    ++iteration;
  }
  report.cg_iterations = iteration;
  report.relative_residual = r.norm() / rhs_norm;
}

}  // namespace hapvox::engine::fem
