#include "engine/fem/dofs.h"

#include <gtest/gtest.h>

#include "engine/errors.h"

namespace hapvox::engine::fem {
namespace {

TEST(DofPartition, NumbersFreeAndConstrainedDofsInOrder) {
  const DofPartition partition(9, {7, 1, 4, 1});
  EXPECT_EQ(partition.constrained_dofs(), (std::vector<int>{1, 4, 7}));
  EXPECT_EQ(partition.free_dofs(), (std::vector<int>{0, 2, 3, 5, 6, 8}));
  EXPECT_EQ(partition.free_index(0), 0);
  EXPECT_EQ(partition.free_index(1), -1);
  EXPECT_EQ(partition.free_index(8), 5);
  EXPECT_FALSE(partition.is_free(4));
}

TEST(DofPartition, SplitsAndRejoinsVectors) {
  const DofPartition partition(6, {0, 5});
  Eigen::VectorXd full(6);
  full << 10, 11, 12, 13, 14, 15;
  EXPECT_EQ(partition.free_part(full), Eigen::Vector4d(11, 12, 13, 14));
  Eigen::VectorXd joined = partition.constrained_only(full);
  EXPECT_EQ(joined, (Eigen::VectorXd(6) << 10, 0, 0, 0, 0, 15).finished());
  partition.add_free_part(partition.free_part(full), joined);
  EXPECT_EQ(joined, full);
}

TEST(DofPartition, RejectsADofOutsideTheMesh) {
  EXPECT_THROW(DofPartition(6, {6}), InputError);
  EXPECT_THROW(DofPartition(6, {-1, 2}), InputError);
}

TEST(VertexDofs, AreThreePerVertex) {
  EXPECT_EQ(vertex_dofs(std::vector<int>{2, 0}), (std::vector<int>{6, 7, 8, 0, 1, 2}));
  EXPECT_EQ(dof_index(4, 2), 14);
}

}  // namespace
}  // namespace hapvox::engine::fem
