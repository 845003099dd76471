#include "engine/fem/dofs.h"

#include <algorithm>
#include <string>

#include "engine/check.h"
#include "engine/errors.h"

namespace hapvox::engine::fem {

std::vector<int> vertex_dofs(std::span<const int> vertices) {
  std::vector<int> dofs;
  dofs.reserve(vertices.size() * 3);
  for (int v : vertices) {
    for (int axis = 0; axis < 3; ++axis) dofs.push_back(dof_index(v, axis));
  }
  return dofs;
}

DofPartition::DofPartition(int dof_count, std::vector<int> constrained_dofs)
    : constrained_dofs_(std::move(constrained_dofs)) {
  HAPVOX_CHECK_GE(dof_count, 0);
  std::sort(constrained_dofs_.begin(), constrained_dofs_.end());
  constrained_dofs_.erase(std::unique(constrained_dofs_.begin(), constrained_dofs_.end()),
                          constrained_dofs_.end());
  if (!constrained_dofs_.empty() &&
      (constrained_dofs_.front() < 0 || constrained_dofs_.back() >= dof_count)) {
    const int bad =
        constrained_dofs_.front() < 0 ? constrained_dofs_.front() : constrained_dofs_.back();
    throw InputError("constraints", "DOF " + std::to_string(bad) + " is not one of the " +
                                        std::to_string(dof_count) + " of the mesh");
  }
  free_index_.assign(dof_count, 0);
  for (int dof : constrained_dofs_) free_index_[dof] = -1;
  free_dofs_.reserve(dof_count - constrained_dofs_.size());
  for (int dof = 0; dof < dof_count; ++dof) {
    if (free_index_[dof] < 0) continue;
    free_index_[dof] = static_cast<int>(free_dofs_.size());
    free_dofs_.push_back(dof);
  }
}

Eigen::VectorXd DofPartition::free_part(const Eigen::VectorXd& full) const {
  HAPVOX_CHECK_EQ(full.size(), dof_count());
  Eigen::VectorXd part(free_count());
  for (int f = 0; f < free_count(); ++f) part[f] = full[free_dofs_[f]];
  return part;
}

Eigen::VectorXd DofPartition::constrained_only(const Eigen::VectorXd& full) const {
  HAPVOX_CHECK_EQ(full.size(), dof_count());
  Eigen::VectorXd out = Eigen::VectorXd::Zero(dof_count());
  for (int dof : constrained_dofs_) out[dof] = full[dof];
  return out;
}

void DofPartition::add_free_part(const Eigen::VectorXd& free, Eigen::VectorXd& full) const {
  HAPVOX_CHECK_EQ(free.size(), free_count());
  HAPVOX_CHECK_EQ(full.size(), dof_count());
  for (int f = 0; f < free_count(); ++f) full[free_dofs_[f]] += free[f];
}

}  // namespace hapvox::engine::fem
