#include "engine/fem/linear_fem.h"

#include "engine/check.h"
#include "engine/errors.h"

namespace hapvox::engine::fem {
namespace {

std::vector<TetShape> rest_shapes(const TetMesh& mesh) {
  std::vector<TetShape> shapes;
  shapes.reserve(mesh.tets.size());
  for (const Tet& tet : mesh.tets) {
    const Eigen::Vector3d a = mesh.rest_mm.col(tet[0]), b = mesh.rest_mm.col(tet[1]),
                          c = mesh.rest_mm.col(tet[2]), d = mesh.rest_mm.col(tet[3]);
    shapes.push_back({barycentric_gradients_per_mm(a, b, c, d), signed_volume_mm3(a, b, c, d)});
  }
  return shapes;
}

// Validation runs before any member that depends on valid input is built.
TetMesh validated(TetMesh mesh, std::span<const TetMaterial> materials) {
  validate(mesh, "tet mesh");
  validate_materials(mesh, materials);
  return mesh;
}

}  // namespace

void check_positive_definite(const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>& ldlt) {
  const std::string problem =
      "the constrained DOFs leave the body free to move rigidly (the free stiffness is "
      "singular); fix at least three vertices that are not on one line";
  if (ldlt.info() != Eigen::Success) throw InputError("constraints", problem);
  const Eigen::VectorXd d = ldlt.vectorD();
  if (d.size() == 0) return;
  // A free rigid mode leaves a pivot at round-off level (~1e-16 of the largest); real
  // meshes, graded and with moduli 1e4 apart, stay many orders above this bound.
  if (!(d.minCoeff() > 1e-11 * d.maxCoeff())) throw InputError("constraints", problem);
}

LinearFem::LinearFem(TetMesh mesh, std::span<const TetMaterial> materials,
                     std::span<const int> constrained_dofs)
    : mesh_(validated(std::move(mesh), materials)),
      shapes_(rest_shapes(mesh_)),
      partition_(3 * mesh_.vertex_count(),
                 std::vector<int>(constrained_dofs.begin(), constrained_dofs.end())),
      assembler_(mesh_, partition_) {
  element_k_.reserve(mesh_.tets.size());
  for (int t = 0; t < mesh_.tet_count(); ++t) {
    element_k_.push_back(element_stiffness_n_per_mm(shapes_[t].gradients_per_mm,
                                                    shapes_[t].volume_mm3, materials[t]));
    for (int v : mesh_.tets[t]) {
      if (!partition_.is_free(dof_index(v, 0)) || !partition_.is_free(dof_index(v, 1)) ||
          !partition_.is_free(dof_index(v, 2))) {
        constrained_tets_.push_back(t);
        break;
      }
    }
  }
  const auto element = [this](int t) -> const ElementMatrix& { return element_k_[t]; };
  k_ = assemble_full(mesh_, element);
  k_ff_ = assembler_.zero_matrix();
  assembler_.assemble(element, k_ff_);
  ldlt_.compute(k_ff_);
  check_positive_definite(ldlt_);
}

Eigen::VectorXd LinearFem::solve_mm(const Eigen::VectorXd& loads_n,
                                    const Eigen::VectorXd& prescribed_mm) const {
  const int n = partition_.dof_count();
  if (loads_n.size() != n || prescribed_mm.size() != n) {
    throw InputError("FEM solve", "loads and prescribed displacements need " + std::to_string(n) +
                                      " entries each");
  }
  // Eliminate the constrained DOFs: K_FF u_F = f_F - K_FC u_C, where K_FC u_C is the free
  // part of the elastic force of the prescribed displacements alone.
  Eigen::VectorXd u = partition_.constrained_only(prescribed_mm);
  Eigen::VectorXd prescribed_forces = Eigen::VectorXd::Zero(n);
  for (int t : constrained_tets_) {
    scatter_add(mesh_.tets[t], element_k_[t] * gather(mesh_.tets[t], u), prescribed_forces);
  }
  partition_.add_free_part(
      solve_free(partition_.free_part(loads_n) - partition_.free_part(prescribed_forces)), u);
  return u;
}

Eigen::VectorXd LinearFem::solve_free(const Eigen::VectorXd& rhs_free) const {
  HAPVOX_CHECK_EQ(rhs_free.size(), partition_.free_count());
  return ldlt_.solve(rhs_free);
}

Eigen::VectorXd LinearFem::elastic_forces_n(const Eigen::VectorXd& displacement_mm) const {
  HAPVOX_CHECK_EQ(displacement_mm.size(), partition_.dof_count());
  Eigen::VectorXd forces = Eigen::VectorXd::Zero(partition_.dof_count());
  for (int t = 0; t < mesh_.tet_count(); ++t) {
    const Tet& tet = mesh_.tets[t];
    scatter_add(tet, element_k_[t] * gather(tet, displacement_mm), forces);
  }
  return forces;
}

Eigen::VectorXd LinearFem::reactions_n(const Eigen::VectorXd& displacement_mm,
                                       const Eigen::VectorXd& loads_n) const {
  HAPVOX_CHECK_EQ(loads_n.size(), partition_.dof_count());
  return partition_.constrained_only(elastic_forces_n(displacement_mm) - loads_n);
}

}  // namespace hapvox::engine::fem
