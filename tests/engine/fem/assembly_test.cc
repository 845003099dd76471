#include "engine/fem/assembly.h"

#include <gtest/gtest.h>

#include "engine/fem/tet_mesh.h"

namespace hapvox::engine::fem {
namespace {

// An element matrix whose every entry is distinct, so a misplaced entry shows.
ElementMatrix numbered(int t) {
  ElementMatrix k;
  for (int c = 0; c < 12; ++c) {
    for (int r = 0; r < 12; ++r) k(r, c) = 1000.0 * t + 12 * c + r + 1;
  }
  return k;
}

TEST(FreeStiffnessAssembler, PatternHoldsEveryVertexPairOfTheKuhnLattice) {
  const int a = 3, b = 2, c = 4;  // cells
  const TetMesh mesh = regular_lattice({a + 1, b + 1, c + 1}, 1.0, Eigen::Vector3d::Zero());
  const FreeStiffnessAssembler assembler(mesh, DofPartition(3 * mesh.vertex_count(), {}));
  // Kuhn lattice edges: axis edges, one diagonal per face square, one per cube.
  const int axis_edges = a * (b + 1) * (c + 1) + (a + 1) * b * (c + 1) + (a + 1) * (b + 1) * c;
  const int face_diagonals = a * b * (c + 1) + a * (b + 1) * c + (a + 1) * b * c;
  const int edges = axis_edges + face_diagonals + a * b * c;
  EXPECT_EQ(assembler.zero_matrix().nonZeros(), 9 * (mesh.vertex_count() + 2 * edges));
  EXPECT_EQ(assembler.zero_matrix().norm(), 0.0);
}

TEST(FreeStiffnessAssembler, MatchesADenseSumOverTheFreeRowsAndColumns) {
  const TetMesh mesh = regular_lattice({3, 2, 3}, 1.0, Eigen::Vector3d::Zero());
  const int n = 3 * mesh.vertex_count();
  const DofPartition partition(n, {0, 1, 2, 7, 20, 33});
  const FreeStiffnessAssembler assembler(mesh, partition);
  Eigen::SparseMatrix<double> k_ff = assembler.zero_matrix();
  assembler.assemble(numbered, k_ff);

  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(n, n);
  for (int t = 0; t < mesh.tet_count(); ++t) {
    const ElementMatrix k = numbered(t);
    for (int r = 0; r < 12; ++r) {
      for (int c = 0; c < 12; ++c) {
        dense(3 * mesh.tets[t][r / 3] + r % 3, 3 * mesh.tets[t][c / 3] + c % 3) += k(r, c);
      }
    }
  }
  Eigen::MatrixXd expected(partition.free_count(), partition.free_count());
  for (int i = 0; i < partition.free_count(); ++i) {
    for (int j = 0; j < partition.free_count(); ++j) {
      expected(i, j) = dense(partition.free_dofs()[i], partition.free_dofs()[j]);
    }
  }
  EXPECT_EQ(Eigen::MatrixXd(k_ff), expected);
  EXPECT_EQ(Eigen::MatrixXd(assemble_full(mesh, numbered)), dense);
  // Refilling overwrites rather than accumulates.
  assembler.assemble(numbered, k_ff);
  EXPECT_EQ(Eigen::MatrixXd(k_ff), expected);
}

}  // namespace
}  // namespace hapvox::engine::fem
