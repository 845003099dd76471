#pragma once
// Materials and the constant-strain linear tetrahedron: the element stiffness every FEM mode
// (linear, co-rotational) assembles. Units: E in Pa, lengths in mm, so stiffness comes out
// in N/mm (stress x mm^2 -> x1e-6 N).

#include <Eigen/Core>

#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "engine/fem/tet_mesh.h"

namespace hapvox::engine::fem {

/// An isotropic linear-elastic material.
struct TetMaterial {
  double youngs_pa = 0;
  double poisson = 0;
};

/// Throws InputError(source, ...) unless E is finite and > 0 and -1 < nu < 0.5 (the range
/// where the strain energy is positive definite).
void validate_material(const TetMaterial& material, const std::string& source);

/// Checks one material per tet; an error names the tet and its label ("tet 12 (label 3)").
void validate_materials(const TetMesh& mesh, std::span<const TetMaterial> materials);

/// One material per tet from its label. Throws InputError("label L", ...) for a label with
/// no material or a bad one.
std::vector<TetMaterial> materials_from_labels(const TetMesh& mesh,
                                               const std::map<std::int32_t, TetMaterial>& by_label);

/// Lame's first parameter and the shear modulus, in N/mm^2 (= MPa).
struct Lame {
  double lambda_n_per_mm2 = 0;
  double mu_n_per_mm2 = 0;
};
Lame lame_parameters(const TetMaterial& material);

/// A tet's 12x12 matrix: row and column 3a+i are vertex a's axis i.
using ElementMatrix = Eigen::Matrix<double, 12, 12>;
/// A tet's 12 DOF values, ordered like ElementMatrix rows.
using ElementVector = Eigen::Matrix<double, 12, 1>;

/// The entries of a full DOF vector (3 per vertex) at the tet's vertices.
inline ElementVector gather(const Tet& tet, const Eigen::VectorXd& full) {
  ElementVector local;
  for (int a = 0; a < 4; ++a) local.segment<3>(3 * a) = full.segment<3>(3 * tet[a]);
  return local;
}

/// Adds a tet's 12 values into a full DOF vector.
inline void scatter_add(const Tet& tet, const ElementVector& local, Eigen::VectorXd& full) {
  for (int a = 0; a < 4; ++a) full.segment<3>(3 * tet[a]) += local.segment<3>(3 * a);
}

/// Stiffness (N/mm) of a constant-strain tet with barycentric gradients g (columns, 1/mm)
/// and volume V (mm^3): block (a, b) = V (lambda g_a g_b^T + mu g_b g_a^T + mu g_a.g_b I).
ElementMatrix element_stiffness_n_per_mm(const Eigen::Matrix<double, 3, 4>& gradients_per_mm,
                                         double volume_mm3, const TetMaterial& material);

}  // namespace hapvox::engine::fem
