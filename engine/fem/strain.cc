#include "engine/fem/strain.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <string>

#include "engine/errors.h"

namespace hapvox::engine::fem {

Eigen::Matrix3d tet_strain(const TetMesh& mesh, int t, const Eigen::VectorXd& displacement_mm) {
  const Tet& tet = mesh.tets[static_cast<std::size_t>(t)];
  const Eigen::Matrix<double, 3, 4> g =
      barycentric_gradients_per_mm(mesh.rest_mm.col(tet[0]), mesh.rest_mm.col(tet[1]),
                                   mesh.rest_mm.col(tet[2]), mesh.rest_mm.col(tet[3]));
  Eigen::Matrix3d grad_u = Eigen::Matrix3d::Zero();
  for (int a = 0; a < 4; ++a)
    grad_u += displacement_mm.segment<3>(3 * tet[a]) * g.col(a).transpose();
  return 0.5 * (grad_u + grad_u.transpose());
}

double equivalent_strain(const Eigen::Matrix3d& strain) {
  const Eigen::Matrix3d deviator = strain - strain.trace() / 3.0 * Eigen::Matrix3d::Identity();
  return std::sqrt(2.0 / 3.0 * deviator.squaredNorm());
}

double strain_norm(const Eigen::Matrix3d& strain) { return strain.norm(); }

std::map<std::int32_t, LabelStrain> mean_strain_by_label(const TetMesh& mesh,
                                                         const Eigen::VectorXd& displacement_mm) {
  if (displacement_mm.size() != 3 * static_cast<Eigen::Index>(mesh.vertex_count())) {
    throw InputError("fem displacement", std::to_string(displacement_mm.size()) + " values for " +
                                             std::to_string(mesh.vertex_count()) +
                                             " vertices (expected 3 per vertex)");
  }
  std::map<std::int32_t, LabelStrain> by_label;
  for (int t = 0; t < mesh.tet_count(); ++t) {
    const Tet& tet = mesh.tets[static_cast<std::size_t>(t)];
    const double volume_mm3 = signed_volume_mm3(mesh.rest_mm.col(tet[0]), mesh.rest_mm.col(tet[1]),
                                                mesh.rest_mm.col(tet[2]), mesh.rest_mm.col(tet[3]));
    const Eigen::Matrix3d strain = tet_strain(mesh, t, displacement_mm);
    LabelStrain& s = by_label[mesh.labels[static_cast<std::size_t>(t)]];
    s.tet_count += 1;
    s.volume_mm3 += volume_mm3;
    s.mean_strain_norm += volume_mm3 * strain_norm(strain);
    s.mean_equivalent_strain += volume_mm3 * equivalent_strain(strain);
    s.max_strain_norm = std::max(s.max_strain_norm, strain_norm(strain));
  }
  for (auto& [label, s] : by_label) {
    s.mean_strain_norm /= s.volume_mm3;
    s.mean_equivalent_strain /= s.volume_mm3;
  }
  return by_label;
}

}  // namespace hapvox::engine::fem
