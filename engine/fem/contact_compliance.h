#pragma once
// The condensed contact compliance W = H K^-1 H^T of a few contact vertices (H picks their
// DOFs): the FEM thread builds it from solves with its prefactored stiffness, and the 1 kHz
// force thread turns the tool's prescribed contact displacements u_c into the contact
// reaction f_c = W^-1 u_c without touching K. Exact for linear statics. Fixed-capacity
// storage: after construction the per-tick call neither allocates nor throws.

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <array>
#include <functional>
#include <span>

#include "engine/fem/dofs.h"
#include "engine/fem/linear_fem.h"

namespace hapvox::engine::fem {

/// Solves K_FF z = rhs over the free DOFs of a partition.
using FreeSolve = std::function<Eigen::VectorXd(const Eigen::VectorXd&)>;

/// W = H K_FF^-1 H^T of `vertices` (each with all three DOFs free; not checked here), one
/// solve per contact DOF: column j is the contact displacements under a unit force on
/// contact DOF j; row and column 3c + i are vertex c's axis i. `w_mm_per_n` must be
/// 3n x 3n. What ContactCompliance and the FEM thread's contact snapshots both build.
void condensed_compliance(const DofPartition& partition, std::span<const int> vertices,
                          const FreeSolve& solve_free, Eigen::Ref<Eigen::MatrixXd> w_mm_per_n);

class ContactCompliance {
 public:
  static constexpr int kMaxVertices = 16;
  static constexpr int kMaxDofs = 3 * kMaxVertices;
  using Matrix =
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxDofs, kMaxDofs>;
  using Vector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxDofs, 1>;
  using FreeSolve = fem::FreeSolve;

  /// W for `contact_vertices` (at most kMaxVertices, distinct, each with all three DOFs
  /// free), one solve per contact DOF. Throws InputError("contact set", ...) otherwise.
  ContactCompliance(const DofPartition& partition, std::span<const int> contact_vertices,
                    const FreeSolve& solve_free);
  /// W from a linear FEM's prefactored stiffness.
  ContactCompliance(const LinearFem& fem, std::span<const int> contact_vertices);

  int vertex_count() const noexcept { return vertex_count_; }
  int dof_count() const noexcept { return 3 * vertex_count_; }
  std::span<const int> vertices() const noexcept {
    return {vertices_.data(), std::size_t(vertex_count_)};
  }
  /// W (mm/N): row and column 3c + i are contact vertex c's axis i.
  const Matrix& compliance_mm_per_n() const noexcept { return w_; }

  /// The forces (N) the contact vertices need to sit displaced by `u_c_mm` from where they
  /// rest without contact (the other constraints and loads held): f_c = W^-1 u_c. Both
  /// spans have dof_count() entries; otherwise nothing is written and it returns false.
  /// No allocation, no exception: callable from the 1 kHz thread.
  bool contact_forces_n(std::span<const double> u_c_mm, std::span<double> f_c_n) const noexcept;

 private:
  std::array<int, kMaxVertices> vertices_{};
  int vertex_count_ = 0;
  Matrix w_;
  Eigen::LLT<Matrix> llt_;
};

}  // namespace hapvox::engine::fem
