#pragma once
// Co-rotational (stiffness-warping) FEM: each tet's linear stiffness acts in its own rotated
// frame, f_e = R_e K_e (R_e^T x_e - X_e), with R_e the polar rotation of its deformation
// gradient. Large rotations then cost no spurious force, where linear FEM inflates or
// shrinks a rotated body. Each step freezes the rotations of a guess and solves the warped
// system K_R = sum R_e K_e R_e^T: re-factorised on small meshes, by conjugate gradients
// preconditioned with the rest factor (rotated per vertex) on large ones.

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <span>
#include <vector>

#include "engine/fem/linear_fem.h"

namespace hapvox::engine::fem {

struct CorotationalOptions {
  /// Up to this many free DOFs a step re-factorises the warped K_FF (an exact solve); above
  /// it, preconditioned CG, whose steps cost a few rest-factor solves instead.
  int refactor_max_free_dofs = 6000;
  /// CG stops at |r| <= this x |rhs|, or after cg_max_iterations.
  double cg_relative_residual = 1e-12;
  int cg_max_iterations = 500;
};

/// What one step did.
struct CorotationalStepReport {
  bool refactorised = false;
  int cg_iterations = 0;
  /// |K_R u_F - rhs| / |rhs| over the free DOFs (CG only; 0 after a factorisation).
  double relative_residual = 0;
};

class CorotationalFem {
 public:
  /// As LinearFem (the same validation and InputErrors), plus the warped-system options.
  CorotationalFem(TetMesh mesh, std::span<const TetMaterial> materials,
                  std::span<const int> constrained_dofs, CorotationalOptions options = {});

  /// The rest state: mesh, partition, element stiffnesses and the rest factor.
  const LinearFem& rest() const { return rest_; }
  const CorotationalOptions& options() const { return options_; }

  /// Elastic forces (N) sum R_e K_e (R_e^T x_e - X_e), with each R_e taken from
  /// `displacement_mm` itself.
  Eigen::VectorXd elastic_forces_n(const Eigen::VectorXd& displacement_mm) const;

  /// One stiffness-warping step: the rotations of `guess_mm`, frozen, then the equilibrium
  /// of the warped system for `loads_n` and `prescribed_mm` (as LinearFem::solve_mm).
  /// Returns the displacement (mm).
  Eigen::VectorXd step_mm(const Eigen::VectorXd& guess_mm, const Eigen::VectorXd& loads_n,
                          const Eigen::VectorXd& prescribed_mm,
                          CorotationalStepReport* report = nullptr);

  /// Steps from `guess_mm` until no DOF moves by more than `tolerance_mm` in a step, or
  /// `max_steps` were taken (their number goes to `steps_taken`). A fixed point balances the
  /// co-rotational forces exactly.
  Eigen::VectorXd solve_mm(const Eigen::VectorXd& guess_mm, const Eigen::VectorXd& loads_n,
                           const Eigen::VectorXd& prescribed_mm, double tolerance_mm, int max_steps,
                           int* steps_taken = nullptr);

  /// K_R,FF^-1 rhs with the rotations of the last step (the rest ones before any step),
  /// e.g. for a contact compliance that follows the warped body.
  Eigen::VectorXd solve_free(const Eigen::VectorXd& rhs_free) const;

  /// The tet rotations of the last step (identity before any).
  const std::vector<Eigen::Matrix3d>& rotations() const { return rotations_; }

 private:
  std::vector<Eigen::Matrix3d> rotations_of(const Eigen::VectorXd& displacement_mm) const;
  ElementMatrix warped(int tet) const;
  // sum R_e K_e (R_e^T x_e - X_e) with the given rotations.
  Eigen::VectorXd forces_n(const std::vector<Eigen::Matrix3d>& rotations,
                           const Eigen::VectorXd& displacement_mm) const;
  // Conjugate gradients on K_R,FF x = rhs from x (the warm start), preconditioned with
  // S K_FF^-1 S^T, S rotating each wholly free vertex by its vertex rotation.
  void conjugate_gradients(const Eigen::VectorXd& rhs, Eigen::VectorXd& x,
                           CorotationalStepReport& report) const;
  Eigen::VectorXd precondition(const Eigen::VectorXd& residual) const;

  LinearFem rest_;
  CorotationalOptions options_;
  std::vector<Eigen::Matrix3d> rotations_;
  std::vector<double> tet_volumes_mm3_;
  // First free index of each vertex whose three DOFs are all free (consecutive), else -1.
  std::vector<int> free_vertex_start_;
  std::vector<Eigen::Matrix3d> vertex_rotations_;
  Eigen::SparseMatrix<double> warped_ff_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> warped_ldlt_;
  bool use_warped_factor_ = false;
  bool stepped_ = false;
};

}  // namespace hapvox::engine::fem
