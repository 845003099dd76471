#pragma once
// Rotations of deformed tets and vertices: the polar decomposition that co-rotational FEM
// warps element stiffness with, and per-vertex rotations (for preconditioning, and for
// rotating gradients when shading the deformed volume, as Nakao's R = N'N^T does).

#include <Eigen/Core>

#include <vector>

#include "engine/fem/element.h"
#include "engine/fem/tet_mesh.h"

namespace hapvox::engine::fem {

/// R of the polar decomposition F = R S (S symmetric positive semidefinite). When det F <= 0
/// (an inverted tet) the proper rotation closest to F, so R is always a rotation.
Eigen::Matrix3d polar_rotation(const Eigen::Matrix3d& f);

/// The deformation gradient F = I + sum_a u_a g_a^T of a tet with barycentric gradients g
/// and vertex displacements u (ordered like an ElementVector).
Eigen::Matrix3d deformation_gradient(const Eigen::Matrix<double, 3, 4>& gradients_per_mm,
                                     const ElementVector& displacement_mm);

/// Each vertex's rotation: the polar rotation of the volume-weighted sum of the rotations of
/// the tets around it (identity for a vertex in no tet).
std::vector<Eigen::Matrix3d> vertex_rotations(const TetMesh& mesh,
                                              const std::vector<Eigen::Matrix3d>& tet_rotations,
                                              const std::vector<double>& tet_volumes_mm3);

}  // namespace hapvox::engine::fem
