#include "engine/fem/tet_mesh.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstring>
#include <numbers>

#include "engine/errors.h"

namespace hapvox::engine::fem {
namespace {

const Eigen::Vector3d kTetMeshOrigin(-3.1, 2.2, 10.5);

TEST(RegularLattice, HasSixTetsPerCube) {
  EXPECT_EQ(regular_lattice({2, 2, 2}, 1.0, kTetMeshOrigin).tet_count(), 6);
  const TetMesh mesh = regular_lattice({3, 4, 5}, 0.7, kTetMeshOrigin);
  EXPECT_EQ(mesh.tet_count(), 6 * 2 * 3 * 4);
  EXPECT_EQ(mesh.vertex_count(), 3 * 4 * 5);
  EXPECT_EQ(mesh.labels.size(), mesh.tets.size());
}

TEST(RegularLattice, VerticesSitOnTheGrid) {
  const TetMesh mesh = regular_lattice({3, 4, 5}, 0.7, kTetMeshOrigin);
  // Vertex (i, j, k) is number i + n_x (j + n_y k).
  const Eigen::Vector3d expected = kTetMeshOrigin + 0.7 * Eigen::Vector3d(2, 1, 3);
  EXPECT_NEAR((mesh.rest_mm.col(2 + 3 * (1 + 4 * 3)) - expected).norm(), 0, 1e-12);
}

TEST(RegularLattice, FillsTheBoxWithPositiveTetsOfAFixedShape) {
  const double h = 0.7;
  const TetMesh mesh = regular_lattice({5, 4, 6}, h, kTetMeshOrigin);
  const MeshQuality quality = mesh_quality(mesh);
  const double box = (4 * h) * (3 * h) * (5 * h);
  EXPECT_NEAR(quality.total_volume_mm3 / box, 1.0, 1e-12);
  EXPECT_EQ(quality.inverted_tets, 0);
  // Every Kuhn tet is a sixth of its cube.
  EXPECT_NEAR(quality.min_volume_mm3 / (h * h * h / 6), 1.0, 1e-12);
  EXPECT_NEAR(quality.max_volume_mm3 / (h * h * h / 6), 1.0, 1e-12);
  for (const Tet& tet : mesh.tets) {
    ASSERT_GT(signed_volume_mm3(mesh.rest_mm.col(tet[0]), mesh.rest_mm.col(tet[1]),
                                mesh.rest_mm.col(tet[2]), mesh.rest_mm.col(tet[3])),
              0);
  }
}

TEST(RegularLattice, DihedralAnglesLieBetween45And90Degrees) {
  const MeshQuality quality = mesh_quality(regular_lattice({4, 3, 5}, 1.3, kTetMeshOrigin));
  // The Kuhn tet has dihedral angles of exactly 45, 60 and 90 degrees.
  EXPECT_NEAR(quality.min_dihedral_deg, 45.0, 1e-9);
  EXPECT_NEAR(quality.max_dihedral_deg, 90.0, 1e-9);
}

TEST(RegularLattice, IsConformingWithAClosedOutwardSurface) {
  const double h = 0.5;
  const int nx = 4, ny = 3, nz = 5;
  const TetMesh mesh = regular_lattice({nx, ny, nz}, h, kTetMeshOrigin);
  const std::vector<Triangle> surface = boundary_faces(mesh);
  // A face two cubes share is cut the same way from both sides, so the only unmatched faces
  // are the two triangles of each square on the box's surface.
  const int squares = (nx - 1) * (ny - 1) + (ny - 1) * (nz - 1) + (nx - 1) * (nz - 1);
  EXPECT_EQ(static_cast<int>(surface.size()), 2 * 2 * squares);
  // Outward orientation: the area vectors of a closed surface sum to zero, and the
  // divergence theorem gives the enclosed volume as (1/3) sum of centroid . area vector.
  Eigen::Vector3d area_sum = Eigen::Vector3d::Zero();
  double volume = 0;
  for (const Triangle& f : surface) {
    const Eigen::Vector3d a = mesh.rest_mm.col(f[0]), b = mesh.rest_mm.col(f[1]),
                          c = mesh.rest_mm.col(f[2]);
    const Eigen::Vector3d area = 0.5 * (b - a).cross(c - a);
    area_sum += area;
    volume += (a + b + c).dot(area) / 9.0;
  }
  EXPECT_LT(area_sum.norm(), 1e-12);
  const double box = (nx - 1) * h * (ny - 1) * h * (nz - 1) * h;
  EXPECT_NEAR(volume / box, 1.0, 1e-12);
}

TEST(RegularLattice, SameInputGivesAByteIdenticalMesh) {
  const TetMesh first = regular_lattice({6, 5, 4}, 0.37, kTetMeshOrigin, 3);
  const TetMesh second = regular_lattice({6, 5, 4}, 0.37, kTetMeshOrigin, 3);
  ASSERT_EQ(first.rest_mm.size(), second.rest_mm.size());
  ASSERT_EQ(first.tets.size(), second.tets.size());
  ASSERT_EQ(first.labels.size(), second.labels.size());
  EXPECT_EQ(std::memcmp(first.rest_mm.data(), second.rest_mm.data(),
                        sizeof(double) * first.rest_mm.size()),
            0);
  EXPECT_EQ(std::memcmp(first.tets.data(), second.tets.data(), sizeof(Tet) * first.tets.size()), 0);
  EXPECT_EQ(std::memcmp(first.labels.data(), second.labels.data(),
                        sizeof(std::int32_t) * first.labels.size()),
            0);
  EXPECT_EQ(first.labels.front(), 3);
}

TEST(RegularLattice, RejectsBadArguments) {
  EXPECT_THROW(regular_lattice({1, 3, 3}, 1.0, kTetMeshOrigin), InputError);
  EXPECT_THROW(regular_lattice({3, 3, 3}, 0.0, kTetMeshOrigin), InputError);
  EXPECT_THROW(regular_lattice({3, 3, 3}, std::nan(""), kTetMeshOrigin), InputError);
  EXPECT_THROW(regular_lattice({2000, 2000, 2000}, 1.0, kTetMeshOrigin), InputError);
}

TEST(TetGeometry, BarycentricGradientsAreDualToTheEdges) {
  const Eigen::Vector3d x[4] = {
      {0.1, 0.2, -0.3}, {2.0, 0.1, 0.4}, {0.5, 1.7, 0.2}, {0.3, 0.4, 2.2}};
  const Eigen::Matrix<double, 3, 4> g = barycentric_gradients_per_mm(x[0], x[1], x[2], x[3]);
  // lambda_k(x_l) = delta_kl, and lambda is linear: g_k . (x_l - x_0) = delta_kl - delta_k0.
  for (int k = 0; k < 4; ++k) {
    for (int l = 1; l < 4; ++l) {
      const double expected = (k == l ? 1.0 : 0.0) - (k == 0 ? 1.0 : 0.0);
      EXPECT_NEAR(g.col(k).dot(x[l] - x[0]), expected, 1e-14) << k << " " << l;
    }
  }
}

TEST(TetGeometry, RegularTetrahedronHasTheDihedralArccosOneThird) {
  const Eigen::Vector3d a(1, 1, 1), b(1, -1, -1), c(-1, 1, -1), d(-1, -1, 1);
  const double volume = signed_volume_mm3(a, b, c, d);
  // Edge 2 sqrt 2: volume = edge^3 / (6 sqrt 2) = 8/3; orientation decides the sign.
  EXPECT_NEAR(std::abs(volume), 8.0 / 3.0, 1e-14);
  const double expected = std::acos(1.0 / 3.0) * 180.0 / std::numbers::pi;
  for (double angle : dihedral_angles_deg(a, b, c, d)) EXPECT_NEAR(angle, expected, 1e-12);
}

TEST(TetGeometry, DeformedVolumeScalesWithTheCubeOfAStretch) {
  const TetMesh mesh = regular_lattice({3, 3, 4}, 1.0, kTetMeshOrigin);
  const Eigen::Matrix3d stretch = Eigen::Vector3d(1.1, 0.9, 1.3).asDiagonal();
  const Eigen::Matrix3Xd moved = stretch * mesh.rest_mm;
  EXPECT_NEAR(deformed_volume_mm3(mesh, moved) / (2 * 2 * 3 * 1.1 * 0.9 * 1.3), 1.0, 1e-12);
}

TEST(Validate, AcceptsTheLatticeAndNamesTheBadTet) {
  TetMesh mesh = regular_lattice({3, 3, 3}, 1.0, kTetMeshOrigin);
  EXPECT_NO_THROW(validate(mesh, "mesh.h5"));
  std::swap(mesh.tets[5][2], mesh.tets[5][3]);  // inverted
  try {
    validate(mesh, "mesh.h5");
    FAIL() << "an inverted tet was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), "mesh.h5");
    EXPECT_NE(e.problem().find("tet 5 "), std::string::npos) << e.what();
  }
  std::swap(mesh.tets[5][2], mesh.tets[5][3]);
  mesh.tets[7][1] = mesh.vertex_count();
  EXPECT_THROW(validate(mesh, "mesh.h5"), InputError);
  mesh.tets[7][1] = mesh.tets[7][0];
  EXPECT_THROW(validate(mesh, "mesh.h5"), InputError);
  mesh = regular_lattice({3, 3, 3}, 1.0, kTetMeshOrigin);
  mesh.labels.pop_back();
  EXPECT_THROW(validate(mesh, "mesh.h5"), InputError);
}

}  // namespace
}  // namespace hapvox::engine::fem
