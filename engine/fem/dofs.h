#pragma once
// Degrees of freedom: vertex v's displacement along axis i is DOF 3v + i. A DofPartition
// splits them into free ones (solved for) and constrained ones (prescribed: Dirichlet
// conditions by elimination), so a roller can hold one axis of a vertex and leave the others.

#include <Eigen/Core>

#include <span>
#include <vector>

namespace hapvox::engine::fem {

/// DOF of `vertex` along `axis` (0, 1, 2 = x, y, z).
constexpr int dof_index(int vertex, int axis) { return 3 * vertex + axis; }

/// The three DOFs of each vertex in `vertices`, in order.
std::vector<int> vertex_dofs(std::span<const int> vertices);

/// Free and constrained DOFs, each numbered in increasing DOF order.
class DofPartition {
 public:
  /// Throws InputError("constraints", ...) when a DOF lies outside [0, dof_count).
  /// Duplicates are merged.
  DofPartition(int dof_count, std::vector<int> constrained_dofs);

  int dof_count() const { return static_cast<int>(free_index_.size()); }
  int free_count() const { return static_cast<int>(free_dofs_.size()); }
  int constrained_count() const { return static_cast<int>(constrained_dofs_.size()); }
  const std::vector<int>& free_dofs() const { return free_dofs_; }
  const std::vector<int>& constrained_dofs() const { return constrained_dofs_; }
  /// Position of `dof` among the free DOFs; -1 when it is constrained.
  int free_index(int dof) const { return free_index_[dof]; }
  bool is_free(int dof) const { return free_index_[dof] >= 0; }

  /// The entries of a full vector (dof_count) at the free DOFs.
  Eigen::VectorXd free_part(const Eigen::VectorXd& full) const;
  /// A full vector with the constrained entries of `full` and zeros at the free DOFs.
  Eigen::VectorXd constrained_only(const Eigen::VectorXd& full) const;
  /// Adds `free` (free_count) into the free entries of `full`.
  void add_free_part(const Eigen::VectorXd& free, Eigen::VectorXd& full) const;

 private:
  std::vector<int> free_dofs_;
  std::vector<int> constrained_dofs_;
  std::vector<int> free_index_;
};

}  // namespace hapvox::engine::fem
