#pragma once
// How the precomputed density gradient turns when the proxy mesh deforms the volume (Nakao
// et al. 2010, §4.2), so that shading follows the material:
//
//   per-vertex rotation   each vertex i has a local frame N_i, the Gram-Schmidt
//                         orthonormalisation of the edges to two of its neighbours (Eq. 1);
//                         the same edges deformed give N'_i (Eq. 2), and R_i = N'_i N_i^T
//                         (Eq. 3-4: N_i is orthogonal, so no inverse). Inside a tet R is the
//                         barycentric blend of its vertices' R_i, applied to the gradient.
//   per-tet F^-T          the exact normal transform of the tet's affine map x = F X + c,
//                         F = D' D^-1 (D, D' its edge matrices at rest and deformed):
//                         g' = F^-T g. Exact under stretch and shear too, where R sees only
//                         the rotation, but constant per tet, so it jumps across faces.
//
// docs/render.md compares the two. Both are exact for a rigid motion.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "engine/fem/tet_mesh.h"

namespace hapvox::render {

enum class GradientTransform { kVertexRotation, kTetInverseTranspose };

/// "rotation" / "inverse-transpose"; parse throws InputError(source, ...).
const char* gradient_transform_name(GradientTransform transform);
GradientTransform parse_gradient_transform(const std::string& name, const std::string& source);

/// The orthonormal frame (n1, n2, n3) as columns: n1 = e1 / |e1|, n2 the part of e2 normal to
/// n1, normalised, n3 = n1 x n2 (right-handed). e1 and e2 must not be parallel.
Eigen::Matrix3d gram_schmidt_frame(const Eigen::Vector3d& e1, const Eigen::Vector3d& e2);

/// For each vertex, the two neighbours (vertices sharing a tet edge) whose rest edges are
/// closest to orthogonal: the best-conditioned frame. Ties go to the lower indices, so the
/// choice is deterministic. Every vertex of a valid mesh has two such neighbours.
std::vector<std::array<std::int32_t, 2>> frame_neighbours(const engine::fem::TetMesh& mesh);

/// R_i = N'_i N_i^T of vertex i, its position and its neighbours' deformed by
/// `displacement_mm` (3 per vertex).
Eigen::Matrix3d vertex_rotation(const engine::fem::TetMesh& mesh,
                                const std::array<std::int32_t, 2>& neighbours, std::int32_t vertex,
                                const Eigen::Ref<const Eigen::VectorXd>& displacement_mm);

/// F^-T of tet `tet` under `displacement_mm`; the identity for a degenerate deformed tet.
Eigen::Matrix3d tet_inverse_transpose(const engine::fem::TetMesh& mesh, std::int32_t tet,
                                      const Eigen::Ref<const Eigen::VectorXd>& displacement_mm);

}  // namespace hapvox::render
