#include "engine/fem/contact_compliance.h"

#include <algorithm>
#include <string>

#include "engine/check.h"
#include "engine/errors.h"

namespace hapvox::engine::fem {

void condensed_compliance(const DofPartition& partition, std::span<const int> vertices,
                          const FreeSolve& solve_free, Eigen::Ref<Eigen::MatrixXd> w_mm_per_n) {
  const int m = 3 * static_cast<int>(vertices.size());
  HAPVOX_CHECK_EQ(w_mm_per_n.rows(), m);
  HAPVOX_CHECK_EQ(w_mm_per_n.cols(), m);
  Eigen::VectorXd unit = Eigen::VectorXd::Zero(partition.free_count());
  for (int j = 0; j < m; ++j) {
    const int free_j = partition.free_index(dof_index(vertices[j / 3], j % 3));
    unit[free_j] = 1.0;
    const Eigen::VectorXd z = solve_free(unit);
    unit[free_j] = 0.0;
    HAPVOX_CHECK_EQ(z.size(), partition.free_count());
    for (int i = 0; i < m; ++i) {
      w_mm_per_n(i, j) = z[partition.free_index(dof_index(vertices[i / 3], i % 3))];
    }
  }
}

ContactCompliance::ContactCompliance(const DofPartition& partition,
                                     std::span<const int> contact_vertices,
                                     const FreeSolve& solve_free) {
  const std::string source = "contact set";
  if (static_cast<int>(contact_vertices.size()) > kMaxVertices) {
    throw InputError(source, std::to_string(contact_vertices.size()) +
                                 " contact vertices; at most " + std::to_string(kMaxVertices));
  }
  const int vertex_total = partition.dof_count() / 3;
  for (std::size_t c = 0; c < contact_vertices.size(); ++c) {
    const int v = contact_vertices[c];
    if (v < 0 || v >= vertex_total) {
      throw InputError(source, "vertex " + std::to_string(v) + " is not one of the " +
                                   std::to_string(vertex_total) + " of the mesh");
    }
    if (std::find(contact_vertices.begin(), contact_vertices.begin() + c, v) !=
        contact_vertices.begin() + c) {
      throw InputError(source, "vertex " + std::to_string(v) + " is listed twice");
    }
    for (int axis = 0; axis < 3; ++axis) {
      if (!partition.is_free(dof_index(v, axis))) {
        throw InputError(source, "vertex " + std::to_string(v) +
                                     " is constrained; contact vertices must be free");
      }
    }
    vertices_[c] = v;
  }
  vertex_count_ = static_cast<int>(contact_vertices.size());

  const int m = dof_count();
  w_.resize(m, m);
  condensed_compliance(partition, vertices(), solve_free, w_);
  if (m == 0) return;
  llt_.compute(w_);  // reads the lower triangle
  // W is a principal block of the SPD K_FF^-1, so this holds for any distinct free vertices.
  HAPVOX_CHECK(llt_.info() == Eigen::Success);
}

ContactCompliance::ContactCompliance(const LinearFem& fem, std::span<const int> contact_vertices)
    : ContactCompliance(fem.partition(), contact_vertices,
                        [&fem](const Eigen::VectorXd& rhs) { return fem.solve_free(rhs); }) {}

bool ContactCompliance::contact_forces_n(std::span<const double> u_c_mm,
                                         std::span<double> f_c_n) const noexcept {
  const auto m = static_cast<std::size_t>(dof_count());
  if (u_c_mm.size() != m || f_c_n.size() != m) return false;
  if (m == 0) return true;
  // Fixed-capacity vector: lives on the stack, and LLT solves in place.
  Vector x(dof_count());
  for (std::size_t i = 0; i < m; ++i) x[i] = u_c_mm[i];
  llt_.solveInPlace(x);
  for (std::size_t i = 0; i < m; ++i) f_c_n[i] = x[i];
  return true;
}

}  // namespace hapvox::engine::fem
