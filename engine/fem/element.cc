#include "engine/fem/element.h"

#include <cmath>
#include <sstream>

#include "engine/errors.h"

namespace hapvox::engine::fem {
namespace {

std::string number(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

}  // namespace

void validate_material(const TetMaterial& material, const std::string& source) {
  if (!(material.youngs_pa > 0) || !std::isfinite(material.youngs_pa)) {
    throw InputError(source, "Young's modulus E = " + number(material.youngs_pa) +
                                 " Pa; it must be finite and > 0");
  }
  // nu -> 0.5 makes lambda infinite (incompressible); nu <= -1 makes the bulk modulus <= 0.
  if (!(material.poisson > -1.0 && material.poisson < 0.5)) {
    throw InputError(
        source, "Poisson's ratio nu = " + number(material.poisson) + "; it must lie in (-1, 0.5)");
  }
}

void validate_materials(const TetMesh& mesh, std::span<const TetMaterial> materials) {
  if (static_cast<int>(materials.size()) != mesh.tet_count()) {
    throw InputError("materials", std::to_string(materials.size()) + " materials for " +
                                      std::to_string(mesh.tet_count()) + " tets");
  }
  for (int t = 0; t < mesh.tet_count(); ++t) {
    validate_material(materials[t], "tet " + std::to_string(t) + " (label " +
                                        std::to_string(mesh.labels[t]) + ")");
  }
}

std::vector<TetMaterial> materials_from_labels(
    const TetMesh& mesh, const std::map<std::int32_t, TetMaterial>& by_label) {
  for (const auto& [label, material] : by_label) {
    validate_material(material, "label " + std::to_string(label));
  }
  std::vector<TetMaterial> materials;
  materials.reserve(mesh.tets.size());
  for (std::int32_t label : mesh.labels) {
    const auto found = by_label.find(label);
    if (found == by_label.end()) {
      throw InputError("label " + std::to_string(label), "has tets but no material");
    }
    materials.push_back(found->second);
  }
  return materials;
}

Lame lame_parameters(const TetMaterial& material) {
  // Pa -> N/mm^2.
  const double e = material.youngs_pa * 1e-6;
  const double nu = material.poisson;
  return {e * nu / ((1 + nu) * (1 - 2 * nu)), e / (2 * (1 + nu))};
}

ElementMatrix element_stiffness_n_per_mm(const Eigen::Matrix<double, 3, 4>& gradients_per_mm,
                                         double volume_mm3, const TetMaterial& material) {
  // From the nodal force of vertex a, V sigma g_a, with sigma = lambda tr(eps) I + 2 mu eps
  // and eps = sym(sum_b u_b g_b^T).
  const Lame lame = lame_parameters(material);
  const auto& g = gradients_per_mm;
  ElementMatrix k;
  for (int a = 0; a < 4; ++a) {
    for (int b = 0; b < 4; ++b) {
      k.block<3, 3>(3 * a, 3 * b) =
          volume_mm3 * (lame.lambda_n_per_mm2 * g.col(a) * g.col(b).transpose() +
                        lame.mu_n_per_mm2 * g.col(b) * g.col(a).transpose() +
                        lame.mu_n_per_mm2 * g.col(a).dot(g.col(b)) * Eigen::Matrix3d::Identity());
    }
  }
  return k;
}

}  // namespace hapvox::engine::fem
