#pragma once
// Meshes, materials and constraints shared by the FEM tests.

#include <Eigen/Core>

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

}  // namespace hapvox::engine::fem::fixtures
