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

/// The co-rotational equilibrium's iteration (CorotationalFem::equilibrium_mm).
struct EquilibriumOptions {
  /// Converged when no free DOF (other than the held ones) is out of balance by more than
  /// this: |f - f_int| <= residual_tolerance_n, in N.
  double residual_tolerance_n = 1e-4;
  int max_iterations = 100;
  /// The safeguard: each update is scaled back until the total energy falls. Off, the
  /// update is taken whole, which is the plain stiffness-warping iteration and can
  /// oscillate and diverge under large rotations
  /// (tests/engine/fem/corotational_equilibrium_test.cc).
  bool line_search = true;
};

/// What an equilibrium solve did.
struct EquilibriumReport {
  int iterations = 0;      // tangent solves
  int halvings = 0;        // line-search step halvings, over all iterations
  double residual_n = 0;   // the largest out-of-balance force left on a free DOF
  bool converged = false;  // residual_n <= the tolerance
  int inverted_tets = 0;   // tets with det F <= 0 at the solution
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

  /// The equilibrium of the co-rotational forces, f_int(u) = loads on the free DOFs, with
  /// `prescribed_mm` on the constrained DOFs and each of `held_dofs` (free DOFs, e.g. the
  /// vertices a tool grabs) held at its `held_mm`. Newton iterations on the total energy
  /// (sum over tets of 1/2 y^T K_e y, y = R^T x - X, less the loads' work), whose gradient the
  /// co-rotational forces are (R is F's polar rotation), with the warped stiffness K_R as
  /// the tangent: K_R is positive definite, so each update is a descent direction, and the
  /// line search makes every iteration lower the energy. The held DOFs are first moved to
  /// their targets along the linear response (K_R^-1 H^T W^-1 (held - u_H)); later updates
  /// leave them still (projected with the first tangent's W = H K_R^-1 H^T). `held_forces_n` (if
  /// given) gets the load each held DOF needs, in `held_dofs` order. Leaves the rotations and
  /// tangent of the solution for solve_free.
  Eigen::VectorXd equilibrium_mm(const Eigen::VectorXd& guess_mm, const Eigen::VectorXd& loads_n,
                                 const Eigen::VectorXd& prescribed_mm,
                                 std::span<const int> held_dofs, std::span<const double> held_mm,
                                 const EquilibriumOptions& options = {},
                                 EquilibriumReport* report = nullptr,
                                 Eigen::VectorXd* held_forces_n = nullptr);

  /// K_R,FF^-1 rhs with the rotations of the last step (the rest ones before any step),
  /// e.g. for a contact compliance that follows the warped body.
  Eigen::VectorXd solve_free(const Eigen::VectorXd& rhs_free) const;

  /// The tet rotations of the last step (identity before any).
  const std::vector<Eigen::Matrix3d>& rotations() const { return rotations_; }

 private:
  std::vector<Eigen::Matrix3d> rotations_of(const Eigen::VectorXd& displacement_mm,
                                            int* inverted_tets = nullptr) const;
  /// Makes `rotations` the current ones: the warped K_FF assembled, and factorised (small
  /// meshes) or the CG preconditioner's vertex rotations updated (large ones).
  void set_tangent(std::vector<Eigen::Matrix3d> rotations);
  /// K_R,FF^-1 for several right-hand sides (the columns), with the current tangent.
  Eigen::MatrixXd solve_free_columns(const Eigen::MatrixXd& rhs_free) const;
  ElementMatrix warped(int tet) const;
  // sum R_e K_e (R_e^T x_e - X_e) with the given rotations.
  // The elastic energy sum 1/2 y^T K_e y goes to `energy_nmm` if given.
  Eigen::VectorXd forces_n(const std::vector<Eigen::Matrix3d>& rotations,
                           const Eigen::VectorXd& displacement_mm,
                           double* energy_nmm = nullptr) const;
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
  // The displacement equilibrium_mm last built the tangent at (empty: none).
  Eigen::VectorXd tangent_at_mm_;
  bool stepped_ = false;
};

}  // namespace hapvox::engine::fem
