#pragma once
// Assembling element matrices into the global stiffness. The free-free block K_FF gets a
// pattern built once with a value slot per element entry, so a co-rotational step (which
// changes values, never the pattern) refills it without searching or allocating.

#include <Eigen/SparseCore>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "engine/check.h"
#include "engine/fem/dofs.h"
#include "engine/fem/element.h"
#include "engine/fem/tet_mesh.h"

namespace hapvox::engine::fem {

/// The whole stiffness (dof_count x dof_count) summed from element(t) for every tet t, where
/// element(t) returns an ElementMatrix.
template <class ElementFn>
Eigen::SparseMatrix<double> assemble_full(const TetMesh& mesh, ElementFn&& element);

/// K_FF's sparsity and the slot of each element entry in it.
class FreeStiffnessAssembler {
 public:
  FreeStiffnessAssembler(const TetMesh& mesh, const DofPartition& partition);

  /// K_FF with every entry zero. Every 3x3 block between two vertices of a tet is stored
  /// whole (zeros included), so a rotated element matrix always fits.
  const Eigen::SparseMatrix<double>& zero_matrix() const { return zero_; }

  /// Overwrites the values of `k_ff` (a copy of zero_matrix()) with the sum over tets t of
  /// element(t)'s free-free entries.
  template <class ElementFn>
  void assemble(ElementFn&& element, Eigen::SparseMatrix<double>& k_ff) const;

 private:
  static constexpr int kEntries = 144;
  Eigen::SparseMatrix<double> zero_;
  // slots_[144 t + i]: index in K_FF's values of entry i (column-major) of tet t's element
  // matrix; -1 when its row or column is constrained.
  std::vector<std::int32_t> slots_;
  int tet_count_ = 0;
};

template <class ElementFn>
Eigen::SparseMatrix<double> assemble_full(const TetMesh& mesh, ElementFn&& element) {
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(mesh.tets.size() * 144);
  for (int t = 0; t < mesh.tet_count(); ++t) {
    const ElementMatrix& k = element(t);
    const Tet& tet = mesh.tets[t];
    for (int c = 0; c < 12; ++c) {
      for (int r = 0; r < 12; ++r) {
        triplets.emplace_back(dof_index(tet[r / 3], r % 3), dof_index(tet[c / 3], c % 3), k(r, c));
      }
    }
  }
  const int n = 3 * mesh.vertex_count();
  Eigen::SparseMatrix<double> full(n, n);
  full.setFromTriplets(triplets.begin(), triplets.end());
  return full;
}

template <class ElementFn>
void FreeStiffnessAssembler::assemble(ElementFn&& element,
                                      Eigen::SparseMatrix<double>& k_ff) const {
  HAPVOX_CHECK_EQ(k_ff.nonZeros(), zero_.nonZeros());
  double* values = k_ff.valuePtr();
  std::fill(values, values + k_ff.nonZeros(), 0.0);
  for (int t = 0; t < tet_count_; ++t) {
    const ElementMatrix& k = element(t);
    const std::int32_t* slot = &slots_[static_cast<std::size_t>(kEntries) * t];
    for (int i = 0; i < kEntries; ++i) {
      if (slot[i] >= 0) values[slot[i]] += k.data()[i];
    }
  }
}

}  // namespace hapvox::engine::fem
