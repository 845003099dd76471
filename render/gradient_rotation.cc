#include "render/gradient_rotation.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <string>

#include "engine/check.h"
#include "engine/errors.h"

namespace hapvox::render {
namespace {

Eigen::Vector3d position(const engine::fem::TetMesh& mesh, std::int32_t v,
                         const Eigen::Ref<const Eigen::VectorXd>& displacement_mm) {
  return mesh.rest_mm.col(v) + displacement_mm.segment<3>(3 * static_cast<Eigen::Index>(v));
}

}  // namespace

const char* gradient_transform_name(GradientTransform transform) {
  return transform == GradientTransform::kVertexRotation ? "rotation" : "inverse-transpose";
}

GradientTransform parse_gradient_transform(const std::string& name, const std::string& source) {
  if (name == "rotation") return GradientTransform::kVertexRotation;
  if (name == "inverse-transpose") return GradientTransform::kTetInverseTranspose;
  throw InputError(source,
                   "unknown gradient transform '" + name + "' (rotation or inverse-transpose)");
}

Eigen::Matrix3d gram_schmidt_frame(const Eigen::Vector3d& e1, const Eigen::Vector3d& e2) {
  Eigen::Matrix3d frame;
  const Eigen::Vector3d n1 = e1.normalized();
  const Eigen::Vector3d n2 = (e2 - e2.dot(n1) * n1).normalized();
  frame.col(0) = n1;
  frame.col(1) = n2;
  frame.col(2) = n1.cross(n2);
  return frame;
}

std::vector<std::array<std::int32_t, 2>> frame_neighbours(const engine::fem::TetMesh& mesh) {
  const int n = mesh.vertex_count();
  std::vector<std::vector<std::int32_t>> neighbours(static_cast<std::size_t>(n));
  for (const engine::fem::Tet& tet : mesh.tets) {
    for (int a = 0; a < 4; ++a) {
      for (int b = 0; b < 4; ++b) {
        if (a != b) neighbours[static_cast<std::size_t>(tet[a])].push_back(tet[b]);
      }
    }
  }
  std::vector<std::array<std::int32_t, 2>> chosen(static_cast<std::size_t>(n), {-1, -1});
  for (std::int32_t v = 0; v < n; ++v) {
    std::vector<std::int32_t>& list = neighbours[static_cast<std::size_t>(v)];
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    // The pair whose unit edges span the largest sine: |n_a x n_b| closest to 1.
    double best = 0.0;
    for (std::size_t i = 0; i < list.size(); ++i) {
      const Eigen::Vector3d a = (mesh.rest_mm.col(list[i]) - mesh.rest_mm.col(v)).normalized();
      for (std::size_t j = i + 1; j < list.size(); ++j) {
        const Eigen::Vector3d b = (mesh.rest_mm.col(list[j]) - mesh.rest_mm.col(v)).normalized();
        const double sine = a.cross(b).norm();
        if (sine > best + 1e-12) {
          best = sine;
          chosen[static_cast<std::size_t>(v)] = {list[i], list[j]};
        }
      }
    }
    // A vertex in no tet keeps {-1, -1}: vertex_rotation gives it the identity.
  }
  return chosen;
}

Eigen::Matrix3d vertex_rotation(const engine::fem::TetMesh& mesh,
                                const std::array<std::int32_t, 2>& neighbours, std::int32_t vertex,
                                const Eigen::Ref<const Eigen::VectorXd>& displacement_mm) {
  if (neighbours[0] < 0) return Eigen::Matrix3d::Identity();
  const Eigen::Vector3d p = mesh.rest_mm.col(vertex);
  const Eigen::Matrix3d rest =
      gram_schmidt_frame(mesh.rest_mm.col(neighbours[0]) - p, mesh.rest_mm.col(neighbours[1]) - p);
  const Eigen::Vector3d q = position(mesh, vertex, displacement_mm);
  const Eigen::Matrix3d deformed =
      gram_schmidt_frame(position(mesh, neighbours[0], displacement_mm) - q,
                         position(mesh, neighbours[1], displacement_mm) - q);
  if (!deformed.allFinite()) return Eigen::Matrix3d::Identity();  // edges collapsed
  return deformed * rest.transpose();
}

Eigen::Matrix3d tet_inverse_transpose(const engine::fem::TetMesh& mesh, std::int32_t tet,
                                      const Eigen::Ref<const Eigen::VectorXd>& displacement_mm) {
  const engine::fem::Tet& t = mesh.tets[static_cast<std::size_t>(tet)];
  Eigen::Matrix3d rest, deformed;
  const Eigen::Vector3d x0 = position(mesh, t[0], displacement_mm);
  for (int k = 0; k < 3; ++k) {
    rest.col(k) = mesh.rest_mm.col(t[k + 1]) - mesh.rest_mm.col(t[0]);
    deformed.col(k) = position(mesh, t[k + 1], displacement_mm) - x0;
  }
  // F^-T = (D' D^-1)^-T = D'^-T D^T.
  const double det = deformed.determinant();
  if (!(std::abs(det) > 1e-12 * std::abs(rest.determinant()))) return Eigen::Matrix3d::Identity();
  return deformed.inverse().transpose() * rest.transpose();
}

}  // namespace hapvox::render
