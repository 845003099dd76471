// CorotationalFem::equilibrium_mm: Newton iterations on the co-rotational energy with the
// warped stiffness as tangent and a backtracking line search (see corotational.h). One
// stiffness-warping pass (step_mm) is the same update taken whole; held at a large
// displacement it can flip sign and grow every step, which the line search forbids.

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <string>

#include "engine/check.h"
#include "engine/errors.h"
#include "engine/fem/corotational.h"

namespace hapvox::engine::fem {
namespace {

// Armijo's sufficient decrease: the energy must fall by this share of the slope's promise.
constexpr double kSufficientDecrease = 1e-4;
constexpr int kMaxHalvings = 30;

bool same(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return a.size() == b.size() && a == b;
}

}  // namespace

Eigen::MatrixXd CorotationalFem::solve_free_columns(const Eigen::MatrixXd& rhs_free) const {
  Eigen::MatrixXd out(rhs_free.rows(), rhs_free.cols());
  for (int c = 0; c < rhs_free.cols(); ++c) out.col(c) = solve_free(rhs_free.col(c));
  return out;
}

Eigen::VectorXd CorotationalFem::equilibrium_mm(
    const Eigen::VectorXd& guess_mm, const Eigen::VectorXd& loads_n,
    const Eigen::VectorXd& prescribed_mm, std::span<const int> held_dofs,
    std::span<const double> held_mm, const EquilibriumOptions& options, EquilibriumReport* report,
    Eigen::VectorXd* held_forces_n) {
  const DofPartition& partition = rest_.partition();
  const int n = partition.dof_count();
  if (loads_n.size() != n || prescribed_mm.size() != n || guess_mm.size() != n) {
    throw InputError("FEM step", "guess, loads and prescribed displacements need " +
                                     std::to_string(n) + " entries each");
  }
  HAPVOX_CHECK_EQ(held_dofs.size(), held_mm.size());
  const int held_count = static_cast<int>(held_dofs.size());
  // H: the held DOFs' free indices.
  std::vector<int> held_free(held_dofs.size());
  for (int h = 0; h < held_count; ++h) {
    HAPVOX_CHECK(partition.is_free(held_dofs[h]));
    held_free[h] = partition.free_index(held_dofs[h]);
  }
  // K^-1 H^T and W^-1 = (H K^-1 H^T)^-1 for the tangent they are made with.
  Eigen::MatrixXd k_inv_ht, w_inverse;
  auto project_held = [&] {
    if (held_count == 0) return;
    Eigen::MatrixXd ht = Eigen::MatrixXd::Zero(partition.free_count(), held_count);
    for (int h = 0; h < held_count; ++h) ht(held_free[h], h) = 1.0;
    k_inv_ht = solve_free_columns(ht);
    Eigen::MatrixXd w(held_count, held_count);
    for (int h = 0; h < held_count; ++h) w.row(h) = k_inv_ht.row(held_free[h]);
    w = 0.5 * (w + w.transpose()).eval();
    w_inverse = w.llt().solve(Eigen::MatrixXd::Identity(held_count, held_count));
  };

  Eigen::VectorXd u = partition.constrained_only(prescribed_mm);
  partition.add_free_part(partition.free_part(guess_mm), u);
  const Eigen::VectorXd loads_free = partition.free_part(loads_n);
  EquilibriumReport local;
  Eigen::VectorXd gap(held_count);
  for (int h = 0; h < held_count; ++h) gap(h) = held_mm[h] - u(held_dofs[h]);
  if (held_count > 0 && gap.cwiseAbs().maxCoeff() > 0.0) {
    // To the held targets along the linear response, then exactly there.
    if (!same(u, tangent_at_mm_)) {
      set_tangent(rotations_of(u));
      tangent_at_mm_ = u;
    }
    project_held();
    partition.add_free_part(k_inv_ht * (w_inverse * gap), u);
    for (int h = 0; h < held_count; ++h) u(held_dofs[h]) = held_mm[h];
  }
  // The total energy (elastic less the loads' work on the free DOFs) and the free
  // residual f - f_int, the held DOFs' entries left out of the balance.
  auto evaluate = [&](const Eigen::VectorXd& x, std::vector<Eigen::Matrix3d>& rotations,
                      Eigen::VectorXd& residual) {
    rotations = rotations_of(x, &local.inverted_tets);
    double elastic = 0.0;
    residual = loads_free - partition.free_part(forces_n(rotations, x, &elastic));
    return elastic - loads_free.dot(partition.free_part(x));
  };
  auto balance = [&](const Eigen::VectorXd& residual) {
    Eigen::VectorXd r = residual;
    for (const int f : held_free) r(f) = 0.0;
    return r.size() == 0 ? 0.0 : r.cwiseAbs().maxCoeff();
  };
  std::vector<Eigen::Matrix3d> rotations;
  Eigen::VectorXd residual;
  double energy = evaluate(u, rotations, residual);
  Eigen::VectorXd full_residual = residual;
  local.residual_n = balance(residual);
  while (local.residual_n > options.residual_tolerance_n &&
         local.iterations < options.max_iterations) {
    set_tangent(std::move(rotations));
    tangent_at_mm_ = u;
    ++local.iterations;
    for (const int f : held_free) residual(f) = 0.0;
    Eigen::VectorXd du = solve_free(residual);
    if (held_count > 0) {
      // The first tangent's K^-1 H^T and W^-1 serve every iteration of the call: H K^-1 H^T
      // is W, so the update still leaves the held DOFs exactly still, and the line search
      // keeps it going down; 3 solves a captured vertex each iteration cost more than
      // they saved (CG on the large meshes).
      if (k_inv_ht.size() == 0) project_held();
      Eigen::VectorXd moved(held_count);
      for (int h = 0; h < held_count; ++h) moved(h) = du(held_free[h]);
      du -= k_inv_ht * (w_inverse * moved);
      for (const int f : held_free) du(f) = 0.0;
    }
    // The energy's slope along du, -r . du: below 0 as K_R is positive definite (the held
    // projection, made with the first tangent's W, could tilt it; then the energy must
    // simply not rise).
    const double slope = std::min(0.0, -residual.dot(du));
    double step = 1.0;
    Eigen::VectorXd trial = u, trial_residual;
    std::vector<Eigen::Matrix3d> trial_rotations;
    double trial_energy = 0.0;
    for (int halving = 0;; ++halving) {
      trial = u;
      partition.add_free_part(step * du, trial);
      trial_energy = evaluate(trial, trial_rotations, trial_residual);
      const bool decreased = trial_energy <= energy + kSufficientDecrease * step * slope;
      // Near the solution the energy's change is below its rounding: the residual decides.
      const bool at_rounding = std::abs(step * slope) <= 1e-13 * std::abs(energy) &&
                               balance(trial_residual) < local.residual_n;
      if (!options.line_search || decreased || at_rounding || halving == kMaxHalvings) break;
      step *= 0.5;
      ++local.halvings;
    }
    u = std::move(trial);
    energy = trial_energy;
    rotations = std::move(trial_rotations);
    residual = std::move(trial_residual);
    full_residual = residual;
    local.residual_n = balance(residual);
  }
  local.converged = local.residual_n <= options.residual_tolerance_n;
  // The solution's tangent, for solve_free and the next solve (a held still body: as it is).
  if (!same(u, tangent_at_mm_)) {
    set_tangent(std::move(rotations));
    tangent_at_mm_ = u;
  }
  if (held_forces_n != nullptr) {
    held_forces_n->resize(held_count);
    for (int h = 0; h < held_count; ++h) {
      (*held_forces_n)(h) = loads_free(held_free[h]) - full_residual(held_free[h]);  // f_int
    }
  }
  if (report != nullptr) *report = local;
  return u;
}

}  // namespace hapvox::engine::fem
