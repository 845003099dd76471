#include "engine/fem/mesh_refinement.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstring>

#include "engine/errors.h"
#include "fem_fixtures.h"

namespace hapvox::engine::fem {
namespace {

const Eigen::Vector3d kRefinementOrigin(-1.5, 0.25, 4.0);

// Bisects, `rounds` times, every tet whose bounding box contains `point`.
void refine_at(BisectionMesh& mesh, const Eigen::Vector3d& point, int rounds) {
  for (int round = 0; round < rounds; ++round) {
    std::vector<char> marked(mesh.tet_count(), 0);
    for (int t = 0; t < mesh.tet_count(); ++t) {
      Eigen::AlignedBox3d box;
      for (int v : mesh.tets()[t].vertices) box.extend(mesh.positions_mm()[v]);
      marked[t] = box.contains(point);
    }
    mesh.refine(marked);
  }
}

TEST(BisectionMesh, StartsAsTheKuhnLattice) {
  const BisectionMesh bisection({2, 3, 4}, kRefinementOrigin, Eigen::Vector3d::Constant(0.5));
  const TetMesh lattice = regular_lattice({3, 4, 5}, 0.5, kRefinementOrigin);
  const TetMesh mesh = bisection.to_tet_mesh(7);
  ASSERT_EQ(mesh.tet_count(), lattice.tet_count());
  EXPECT_EQ(mesh.rest_mm, lattice.rest_mm);
  for (int t = 0; t < mesh.tet_count(); ++t) {
    Tet a = mesh.tets[t], b = lattice.tets[t];
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    EXPECT_EQ(a, b) << "tet " << t;
    EXPECT_EQ(mesh.labels[t], 7);
  }
  EXPECT_TRUE(bisection.conforming());
}

TEST(BisectionMesh, ThreeUniformGenerationsGiveTheHalvedKuhnLattice) {
  const double h = 0.8;
  BisectionMesh bisection({2, 2, 3}, kRefinementOrigin, Eigen::Vector3d::Constant(h));
  for (int generation = 0; generation < 3; ++generation) {
    bisection.refine(std::vector<char>(bisection.tet_count(), 1));
  }
  const TetMesh mesh = bisection.to_tet_mesh();
  EXPECT_EQ(mesh.tet_count(), 6 * 4 * 4 * 6);
  EXPECT_EQ(mesh.vertex_count(), 5 * 5 * 7);
  const MeshQuality quality = mesh_quality(mesh);
  EXPECT_NEAR(quality.min_volume_mm3, std::pow(h / 2, 3) / 6, 1e-12);
  EXPECT_NEAR(quality.max_volume_mm3, std::pow(h / 2, 3) / 6, 1e-12);
  EXPECT_NEAR(quality.min_dihedral_deg, 45.0, 1e-9);
  EXPECT_NEAR(quality.max_dihedral_deg, 90.0, 1e-9);
}

TEST(BisectionMesh, LocalRefinementStaysConforming) {
  const double h = 1.0;
  BisectionMesh bisection({4, 3, 3}, kRefinementOrigin, Eigen::Vector3d::Constant(h));
  const int before = bisection.tet_count();
  refine_at(bisection, kRefinementOrigin + Eigen::Vector3d(1.3, 1.1, 0.7), 10);
  EXPECT_TRUE(bisection.conforming());
  EXPECT_GT(bisection.tet_count(), before + 10);
  const TetMesh mesh = bisection.to_tet_mesh();
  fixtures::expect_conforming_box(mesh, kRefinementOrigin,
                                  kRefinementOrigin + h * Eigen::Vector3d(4, 3, 3));
  // Local: tets far from the point keep their lattice size.
  int coarse = 0;
  for (const BisectionTet& tet : bisection.tets()) coarse += tet.generation == 0;
  EXPECT_GT(coarse, before / 3);
}

TEST(BisectionMesh, EveryDescendantHasTheProvenDihedralRange) {
  // Deep refinement at several points reaches all three similarity classes; their angles
  // span exactly the documented range, and no tet leaves it.
  BisectionMesh bisection({3, 3, 3}, kRefinementOrigin, Eigen::Vector3d::Constant(2.0));
  refine_at(bisection, kRefinementOrigin + Eigen::Vector3d(2.9, 3.1, 2.3), 14);
  refine_at(bisection, kRefinementOrigin + Eigen::Vector3d(0.7, 4.6, 5.2), 8);
  const TetMesh mesh = bisection.to_tet_mesh();
  const MeshQuality quality = mesh_quality(mesh);
  EXPECT_NEAR(quality.min_dihedral_deg, kBisectionMinDihedralDeg, 1e-9);
  EXPECT_NEAR(quality.max_dihedral_deg, kBisectionMaxDihedralDeg, 1e-9);
  fixtures::expect_conforming_box(mesh, kRefinementOrigin,
                                  kRefinementOrigin + Eigen::Vector3d::Constant(6.0));
}

TEST(BisectionMesh, IsDeterministic) {
  auto build = [] {
    BisectionMesh bisection({3, 2, 2}, kRefinementOrigin, Eigen::Vector3d(0.9, 1.0, 1.1));
    refine_at(bisection, kRefinementOrigin + Eigen::Vector3d(1.0, 0.6, 1.4), 7);
    return bisection.to_tet_mesh();
  };
  const TetMesh a = build(), b = build();
  ASSERT_EQ(a.vertex_count(), b.vertex_count());
  ASSERT_EQ(a.tet_count(), b.tet_count());
  EXPECT_EQ(std::memcmp(a.rest_mm.data(), b.rest_mm.data(), sizeof(double) * a.rest_mm.size()), 0);
  EXPECT_EQ(a.tets, b.tets);
}

TEST(BisectionMesh, RejectsBadLattices) {
  EXPECT_THROW(BisectionMesh({0, 1, 1}, kRefinementOrigin, Eigen::Vector3d::Ones()), InputError);
  EXPECT_THROW(BisectionMesh({1, 1, 1}, kRefinementOrigin, Eigen::Vector3d(1, 0, 1)), InputError);
}

}  // namespace
}  // namespace hapvox::engine::fem
