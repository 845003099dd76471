#include "engine/fem/rotations.h"

#include <Eigen/LU>
#include <Eigen/SVD>

#include "engine/check.h"

namespace hapvox::engine::fem {

Eigen::Matrix3d polar_rotation(const Eigen::Matrix3d& f) {
  // F = U Sigma V^T gives R = U V^T; flipping the direction of the smallest singular value
  // (Eigen sorts them in decreasing order) makes det R = +1 for an inverted F.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(f, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  const Eigen::Matrix3d& v = svd.matrixV();
  if ((u * v.transpose()).determinant() < 0) u.col(2) = -u.col(2);
  return u * v.transpose();
}

Eigen::Matrix3d deformation_gradient(const Eigen::Matrix<double, 3, 4>& gradients_per_mm,
                                     const ElementVector& displacement_mm) {
  // x = X + u with u linear in the tet: F = dx/dX = I + grad u. Summing u (not x) keeps
  // small deformations exact to round-off.
  Eigen::Matrix3d f = Eigen::Matrix3d::Identity();
  for (int a = 0; a < 4; ++a) {
    f += displacement_mm.segment<3>(3 * a) * gradients_per_mm.col(a).transpose();
  }
  return f;
}

std::vector<Eigen::Matrix3d> vertex_rotations(const TetMesh& mesh,
                                              const std::vector<Eigen::Matrix3d>& tet_rotations,
                                              const std::vector<double>& tet_volumes_mm3) {
  HAPVOX_CHECK_EQ(tet_rotations.size(), mesh.tets.size());
  HAPVOX_CHECK_EQ(tet_volumes_mm3.size(), mesh.tets.size());
  std::vector<Eigen::Matrix3d> sums(mesh.vertex_count(), Eigen::Matrix3d::Zero());
  for (int t = 0; t < mesh.tet_count(); ++t) {
    for (int v : mesh.tets[t]) sums[v] += tet_volumes_mm3[t] * tet_rotations[t];
  }
  for (Eigen::Matrix3d& sum : sums) {
    sum = sum.isZero(0) ? Eigen::Matrix3d::Identity() : polar_rotation(sum);
  }
  return sums;
}

}  // namespace hapvox::engine::fem
