#include "engine/fem/incision.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstring>
#include <numeric>
#include <string>

#include "engine/errors.h"

namespace hapvox::engine::fem {
namespace {

using Eigen::Vector3d;

// A 40 mm cube of 8^3 Kuhn cells (5 mm), vertices on multiples of 5 mm.
TetMesh cube() { return regular_lattice({9, 9, 9}, 5.0, Vector3d::Zero()); }

// The plane y = y_mm across the whole cube's width, from z = 45 down by `depth_mm`.
CutSurface plane_cut(double y_mm, double depth_mm) {
  return swept_polyline({Vector3d(-5, y_mm, 45), Vector3d(45, y_mm, 45)}, Vector3d(0, 0, -depth_mm),
                        "cut");
}

double boundary_area_mm2(const TetMesh& mesh) {
  double area = 0;
  for (const Triangle& f : boundary_faces(mesh)) {
    area += 0.5 * (mesh.rest_mm.col(f[1]) - mesh.rest_mm.col(f[0]))
                      .cross(mesh.rest_mm.col(f[2]) - mesh.rest_mm.col(f[0]))
                      .norm();
  }
  return area;
}

// The tets' connected components (tets sharing a vertex), as a component per tet.
std::vector<int> components(const TetMesh& mesh, int& count) {
  std::vector<int> parent(mesh.vertex_count());
  std::iota(parent.begin(), parent.end(), 0);
  const auto find = [&](int v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const Tet& tet : mesh.tets) {
    for (int k = 1; k < 4; ++k) parent[find(tet[k])] = find(tet[0]);
  }
  std::vector<int> label(mesh.vertex_count(), -1), out;
  count = 0;
  for (const Tet& tet : mesh.tets) {
    const int root = find(tet[0]);
    if (label[root] < 0) label[root] = count++;
    out.push_back(label[root]);
  }
  return out;
}

double tet_volume(const TetMesh& mesh, const Tet& t) {
  return signed_volume_mm3(mesh.rest_mm.col(t[0]), mesh.rest_mm.col(t[1]), mesh.rest_mm.col(t[2]),
                           mesh.rest_mm.col(t[3]));
}

TEST(Incision, ACutThroughTheCubeSeparatesItIntoTheTwoExactSlabs) {
  const TetMesh mesh = cube();
  const IncisedMesh incised = incise(mesh, plane_cut(17.3, 50), "cut");
  validate(incised.mesh, "incised");
  int count = 0;
  const std::vector<int> component = components(incised.mesh, count);
  ASSERT_EQ(count, 2);
  double below = 0, above = 0;
  int side_component[2] = {-1, -1};
  for (int t = 0; t < incised.mesh.tet_count(); ++t) {
    const Tet& tet = incised.mesh.tets[t];
    const double centroid_y =
        0.25 * (incised.mesh.rest_mm(1, tet[0]) + incised.mesh.rest_mm(1, tet[1]) +
                incised.mesh.rest_mm(1, tet[2]) + incised.mesh.rest_mm(1, tet[3]));
    (centroid_y < 17.3 ? below : above) += tet_volume(incised.mesh, tet);
    // One component on each side.
    const int side = centroid_y < 17.3 ? 0 : 1;
    if (side_component[side] < 0) side_component[side] = component[t];
    EXPECT_EQ(component[t], side_component[side]) << "tet " << t;
  }
  EXPECT_NEAR(below, 40 * 40 * 17.3, 1e-9);
  EXPECT_NEAR(above, 40 * 40 * (40 - 17.3), 1e-9);
  // The two new faces: the cube's surface grows by twice the cut's area.
  EXPECT_NEAR(boundary_area_mm2(incised.mesh) - boundary_area_mm2(mesh), 2 * 40 * 40, 1e-8);
  // Every pair: two copies at one point of the plane, the normal towards +y.
  ASSERT_FALSE(incised.pairs.empty());
  EXPECT_EQ(incised.report.cut_pairs, incised.report.crossing_vertices);  // all on the cut
  for (const CutPair& pair : incised.pairs) {
    EXPECT_NEAR(incised.mesh.rest_mm(1, pair.plus), 17.3, 1e-12);
    EXPECT_EQ(incised.mesh.rest_mm.col(pair.plus), incised.mesh.rest_mm.col(pair.minus));
    EXPECT_NEAR((pair.normal - Vector3d::UnitY()).norm(), 0, 1e-12);
  }
}

TEST(Incision, EveryPieceLiesOnOneSideAndThePiecesFillTheirParent) {
  const TetMesh mesh = cube();
  const IncisedMesh incised = incise(mesh, plane_cut(17.3, 50), "cut");
  std::vector<double> filled(mesh.tet_count(), 0.0);
  for (int t = 0; t < incised.mesh.tet_count(); ++t) {
    const Tet& tet = incised.mesh.tets[t];
    double lo = 1e300, hi = -1e300;
    for (const std::int32_t v : tet) {
      lo = std::min(lo, incised.mesh.rest_mm(1, v));
      hi = std::max(hi, incised.mesh.rest_mm(1, v));
    }
    EXPECT_TRUE(hi <= 17.3 + 1e-12 || lo >= 17.3 - 1e-12) << "tet " << t << " spans the cut";
    filled[incised.parent_tet[t]] += tet_volume(incised.mesh, tet);
    EXPECT_EQ(incised.mesh.labels[t], mesh.labels[incised.parent_tet[t]]);
  }
  for (int t = 0; t < mesh.tet_count(); ++t) {
    EXPECT_NEAR(filled[t], tet_volume(mesh, mesh.tets[t]), 1e-12);
  }
  // Every vertex is where its origin says.
  for (int v = 0; v < incised.mesh.vertex_count(); ++v) {
    const SplitVertex& o = incised.origin[v];
    const Vector3d expected = (1 - o.t) * mesh.rest_mm.col(o.a) + o.t * mesh.rest_mm.col(o.b);
    EXPECT_EQ(incised.mesh.rest_mm.col(v), expected) << v;
  }
}

TEST(Incision, APartialCutEndsInACrackFrontAndKeepsTheBodyWhole) {
  const TetMesh mesh = cube();
  const double depth = 20;  // from z = 45 down to z = 25
  const IncisedMesh incised = incise(mesh, plane_cut(17.3, depth), "cut");
  validate(incised.mesh, "incised");
  int count = 0;
  components(incised.mesh, count);
  EXPECT_EQ(count, 1);
  EXPECT_NEAR(mesh_quality(incised.mesh).total_volume_mm3, 40 * 40 * 40, 1e-8);
  // Crossings above z = 25 are all on the cut; those a quarter of the longest edge (5 sqrt 3)
  // below it are not.
  const int first_copy = incised.mesh.vertex_count() - incised.report.cut_pairs;
  std::vector<char> paired(incised.mesh.vertex_count(), 0);
  for (const CutPair& pair : incised.pairs) paired[pair.plus] = 1;
  const double reach = 0.25 * 5 * std::sqrt(3.0);
  for (int v = mesh.vertex_count(); v < first_copy; ++v) {
    const double z = incised.mesh.rest_mm(2, v);
    if (z >= 25) {
      EXPECT_TRUE(paired[v]) << "crossing at z " << z;
    } else if (z < 25 - reach) {
      EXPECT_FALSE(paired[v]) << "crossing at z " << z;
    }
  }
  // The opened faces: 40 mm wide, from z = 40 down to the front (z = 25, give or take an edge).
  const double opened = 0.5 * (boundary_area_mm2(incised.mesh) - boundary_area_mm2(mesh));
  EXPECT_GT(opened, 40 * (15 - 5));
  EXPECT_LT(opened, 40 * (15 + 5));
}

TEST(Incision, AVertexNearlyOnTheCutCountsATenthOfAnEdgeAway) {
  const TetMesh mesh = cube();
  // y = 20.2: the vertex plane y = 20 is 0.2 mm from it, under 0.5 mm (a tenth of 5 mm).
  const IncisedMesh incised = incise(mesh, plane_cut(20.2, 50), "cut");
  validate(incised.mesh, "incised");
  EXPECT_EQ(incised.report.nudged_vertices, 9 * 9);
  const MeshQuality quality = mesh_quality(incised.mesh);
  EXPECT_NEAR(quality.total_volume_mm3, 40 * 40 * 40, 1e-8);
  // No sliver: a crossing lies at least 0.5 / (0.5 + 5) of its edge from a nudged vertex, so
  // the smallest piece is a Kuhn tet (125/6 mm^3) scaled by that fraction on three edges.
  const double fraction = 0.5 / 5.5;
  EXPECT_GT(quality.min_volume_mm3, 0.99 * std::pow(fraction, 3) * 125.0 / 6.0);
  for (const CutPair& pair : incised.pairs) {
    EXPECT_NEAR(incised.mesh.rest_mm(1, pair.plus), 20.2, 0.5);
  }
}

TEST(Incision, ABentCutSplitsConformingly) {
  const TetMesh mesh = cube();
  const CutSurface cut =
      swept_polyline({Vector3d(-5, 8, 45), Vector3d(21, 27.5, 45), Vector3d(45, 12, 45)},
                     Vector3d(3, 1, -30), "bent");
  const IncisedMesh incised = incise(mesh, cut, "bent");
  validate(incised.mesh, "incised");
  EXPECT_NEAR(mesh_quality(incised.mesh).total_volume_mm3, 40 * 40 * 40, 1e-8);
  // Conforming: an interior face is shared by exactly two tets, so the surface grows only by
  // the opened faces, twice over, each pair of copies bounding both.
  // So every face of the surface lies on the cube's faces or is made of crossings only.
  const int n = mesh.vertex_count();
  int opened_faces = 0;
  for (const Triangle& f : boundary_faces(incised.mesh)) {
    bool on_cube = false;
    for (int axis = 0; axis < 3; ++axis) {
      for (const double side : {0.0, 40.0}) {
        on_cube = on_cube || (incised.mesh.rest_mm(axis, f[0]) == side &&
                              incised.mesh.rest_mm(axis, f[1]) == side &&
                              incised.mesh.rest_mm(axis, f[2]) == side);
      }
    }
    const bool crossings = f[0] >= n && f[1] >= n && f[2] >= n;
    EXPECT_TRUE(on_cube || crossings) << f[0] << " " << f[1] << " " << f[2];
    opened_faces += crossings && !on_cube;
  }
  EXPECT_GT(opened_faces, 0);
  // Deterministic to the bit.
  const IncisedMesh again = incise(mesh, cut, "bent");
  ASSERT_EQ(again.mesh.rest_mm.size(), incised.mesh.rest_mm.size());
  EXPECT_EQ(std::memcmp(again.mesh.rest_mm.data(), incised.mesh.rest_mm.data(),
                        sizeof(double) * incised.mesh.rest_mm.size()),
            0);
  EXPECT_EQ(again.mesh.tets, incised.mesh.tets);
}

TEST(Incision, TheOpeningMovesTheCopiesApartAlongTheNormal) {
  const IncisedMesh incised = incise(cube(), plane_cut(17.3, 20), "cut");
  const auto opening = opening_displacements(incised, 4.0);
  ASSERT_EQ(opening.size(), 6 * incised.pairs.size());
  Eigen::VectorXd u = Eigen::VectorXd::Zero(3 * incised.mesh.vertex_count());
  for (const auto& [dof, mm] : opening) u(dof) = mm;
  for (const CutPair& pair : incised.pairs) {
    EXPECT_NEAR((u.segment<3>(3 * pair.plus) - u.segment<3>(3 * pair.minus)).y(), 4.0, 1e-12);
    EXPECT_NEAR(u.segment<3>(3 * pair.plus).y(), 2.0, 1e-12);  // + side moves to +y
  }
}

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(Incision, BadCutsAreOneLineErrorsNamingTheSource) {
  const TetMesh mesh = cube();
  EXPECT_EQ(error_of([&] { incise(mesh, CutSurface{}, "cut.toml"); }),
            "cut.toml: the cut surface has no triangle");
  EXPECT_EQ(error_of([&] { swept_polyline({Vector3d(0, 0, 0)}, Vector3d(0, 0, 1), "cut.toml"); }),
            "cut.toml: the polyline needs at least two points");
  EXPECT_EQ(error_of([&] {
              swept_polyline({Vector3d(0, 0, 0), Vector3d(0, 0, 5)}, Vector3d(0, 0, -1), "c");
            }),
            "c: the sweep is parallel to polyline segment 0");
  EXPECT_EQ(error_of([&] {
              swept_polyline({Vector3d(0, 0, 0), Vector3d(0, 0, 0)}, Vector3d(0, 0, -1), "c");
            }),
            "c: polyline points 0 and 1 coincide");
  // A cut beside the cube: its plane's extension splits the cube, but nothing is on the cut.
  EXPECT_EQ(error_of([&] {
              incise(mesh,
                     swept_polyline({Vector3d(60, 17.3, 45), Vector3d(90, 17.3, 45)},
                                    Vector3d(0, 0, -50), "beside"),
                     "beside");
            }),
            "beside: the cut crosses no element of the mesh");
}

}  // namespace
}  // namespace hapvox::engine::fem
