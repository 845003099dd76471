#include "engine/fem/assembly.h"

namespace hapvox::engine::fem {

FreeStiffnessAssembler::FreeStiffnessAssembler(const TetMesh& mesh, const DofPartition& partition)
    : tet_count_(mesh.tet_count()) {
  HAPVOX_CHECK_EQ(partition.dof_count(), 3 * mesh.vertex_count());
  // Local entry i of a tet (column-major 12x12) sits at free row/column (or -1).
  auto free_dof = [&](const Tet& tet, int local) {
    return partition.free_index(dof_index(tet[local / 3], local % 3));
  };
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(mesh.tets.size() * kEntries);
  for (const Tet& tet : mesh.tets) {
    for (int c = 0; c < 12; ++c) {
      for (int r = 0; r < 12; ++r) {
        const int row = free_dof(tet, r), col = free_dof(tet, c);
        if (row >= 0 && col >= 0) triplets.emplace_back(row, col, 0.0);
      }
    }
  }
  zero_.resize(partition.free_count(), partition.free_count());
  // setFromTriplets keeps explicit zeros: the pattern is structural.
  zero_.setFromTriplets(triplets.begin(), triplets.end());
  zero_.makeCompressed();

  slots_.assign(mesh.tets.size() * kEntries, -1);
  const int* outer = zero_.outerIndexPtr();
  const int* inner = zero_.innerIndexPtr();
  for (int t = 0; t < tet_count_; ++t) {
    for (int c = 0; c < 12; ++c) {
      for (int r = 0; r < 12; ++r) {
        const int row = free_dof(mesh.tets[t], r), col = free_dof(mesh.tets[t], c);
        if (row < 0 || col < 0) continue;
        // Row indices within a compressed column are sorted.
        const int* found = std::lower_bound(inner + outer[col], inner + outer[col + 1], row);
        HAPVOX_CHECK(found != inner + outer[col + 1] && *found == row);
        slots_[static_cast<std::size_t>(kEntries) * t + 12 * c + r] =
            static_cast<std::int32_t>(found - inner);
      }
    }
  }
}

}  // namespace hapvox::engine::fem
