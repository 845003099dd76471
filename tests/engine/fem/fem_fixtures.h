#pragma once
// Meshes, materials and constraints shared by the FEM tests.

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "engine/fem/dofs.h"
#include "engine/fem/element.h"
#include "engine/fem/tet_mesh.h"

namespace hapvox::engine::fem::fixtures {

/// The vertices whose rest position satisfies `where`.
inline std::vector<int> vertices_where(const TetMesh& mesh,
                                       const std::function<bool(const Eigen::Vector3d&)>& where) {
  std::vector<int> out;
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    if (where(mesh.rest_mm.col(v))) out.push_back(v);
  }
  return out;
}

/// The DOF along `axis` of each vertex in `vertices`.
inline std::vector<int> axis_dofs(const std::vector<int>& vertices, int axis) {
  std::vector<int> dofs;
  for (int v : vertices) dofs.push_back(dof_index(v, axis));
  return dofs;
}

/// `mesh` with every vertex not on the box [lo, hi]'s surface moved by up to `fraction` of
/// `spacing_mm` along each axis (a fixed seed: the same mesh every run).
inline TetMesh jittered(TetMesh mesh, double spacing_mm, double fraction) {
  const Eigen::Vector3d lo = mesh.rest_mm.rowwise().minCoeff();
  const Eigen::Vector3d hi = mesh.rest_mm.rowwise().maxCoeff();
  std::mt19937 random(12345);
  std::uniform_real_distribution<double> offset(-fraction * spacing_mm, fraction * spacing_mm);
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    const Eigen::Vector3d x = mesh.rest_mm.col(v);
    const bool on_surface =
        ((x - lo).array().abs() < 1e-9).any() || ((x - hi).array().abs() < 1e-9).any();
    if (on_surface) continue;
    for (int axis = 0; axis < 3; ++axis) mesh.rest_mm(axis, v) += offset(random);
  }
  return mesh;
}

inline std::vector<TetMaterial> uniform(const TetMesh& mesh, TetMaterial material) {
  return std::vector<TetMaterial>(mesh.tets.size(), material);
}

/// Relative size of the difference: |a - b| / |b|.
inline double relative_error(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return (a - b).norm() / b.norm();
}

inline double face_area(const TetMesh& mesh, const Triangle& face) {
  const Eigen::Vector3d a = mesh.rest_mm.col(face[0]);
  return 0.5 * (mesh.rest_mm.col(face[1]) - a).cross(mesh.rest_mm.col(face[2]) - a).norm();
}

// The mesh fills the box [lo, hi] without gaps, overlaps or hanging vertices: positive tets
// whose volumes add up to the box's, and a surface (faces without a twin) that lies on the
// box's faces and has its area. A hanging vertex leaves unpaired faces inside the box.
inline void expect_conforming_box(const TetMesh& mesh, const Eigen::Vector3d& lo,
                                  const Eigen::Vector3d& hi) {
  const MeshQuality quality = mesh_quality(mesh);
  const Eigen::Vector3d size = hi - lo;
  EXPECT_EQ(quality.inverted_tets, 0);
  EXPECT_NEAR(quality.total_volume_mm3 / size.prod(), 1.0, 1e-12);
  double area = 0;
  for (const Triangle& face : boundary_faces(mesh)) {
    area += face_area(mesh, face);
    bool on_box = false;
    for (int axis = 0; axis < 3; ++axis) {
      for (double plane : {lo[axis], hi[axis]}) {
        bool all = true;
        for (int v : face) all = all && std::abs(mesh.rest_mm(axis, v) - plane) < 1e-9;
        on_box = on_box || all;
      }
    }
    ASSERT_TRUE(on_box) << "a surface face inside the box: a hanging vertex";
  }
  const double box_area = 2 * (size.x() * size.y() + size.y() * size.z() + size.z() * size.x());
  EXPECT_NEAR(area / box_area, 1.0, 1e-12);
}

}  // namespace hapvox::engine::fem::fixtures
