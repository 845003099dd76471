#pragma once
// Linear static FEM on a tet mesh (Nakao's proxy mesh): constant-strain tets with per-tet E
// and nu, Dirichlet conditions by elimination, and the free-free stiffness factorised once
// (sparse LDL^T) so every later solve is two triangular sweeps. Units: mm, N, Pa.

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <span>
#include <vector>

#include "engine/fem/assembly.h"
#include "engine/fem/dofs.h"
#include "engine/fem/element.h"
#include "engine/fem/tet_mesh.h"

namespace hapvox::engine::fem {

/// Per-tet geometry at rest, shared by every FEM mode.
struct TetShape {
  /// Barycentric gradients (1/mm), one column per vertex.
  Eigen::Matrix<double, 3, 4> gradients_per_mm;
  double volume_mm3 = 0;
};

class LinearFem {
 public:
  /// Validates the mesh and one material per tet (InputError naming the tet and label),
  /// assembles K and factorises its free-free block. Throws InputError("constraints", ...)
  /// when the constrained DOFs leave a rigid motion free (K_FF singular).
  LinearFem(TetMesh mesh, std::span<const TetMaterial> materials,
            std::span<const int> constrained_dofs);

  const TetMesh& mesh() const { return mesh_; }
  const DofPartition& partition() const { return partition_; }
  const TetShape& shape(int tet) const { return shapes_[tet]; }
  /// Tet t's stiffness (N/mm) at rest.
  const ElementMatrix& element_stiffness(int tet) const { return element_k_[tet]; }
  /// The whole stiffness K (N/mm), all DOFs.
  const Eigen::SparseMatrix<double>& stiffness_n_per_mm() const { return k_; }
  /// The pattern of K_FF, for modes that refill it (co-rotational).
  const FreeStiffnessAssembler& assembler() const { return assembler_; }

  /// Static equilibrium K u = loads + reactions. `loads_n` (dof_count) acts on the free
  /// DOFs (at a constrained DOF the support takes it); `prescribed_mm` (dof_count) gives the
  /// constrained DOFs' displacements (its free entries are not read). Returns u (mm).
  Eigen::VectorXd solve_mm(const Eigen::VectorXd& loads_n,
                           const Eigen::VectorXd& prescribed_mm) const;

  /// K_FF^-1 rhs for a vector over the free DOFs (the prefactored solve).
  Eigen::VectorXd solve_free(const Eigen::VectorXd& rhs_free) const;

  /// K u (N): the forces the elastic body exerts back on its vertices' displacements, summed
  /// per element (no global product).
  Eigen::VectorXd elastic_forces_n(const Eigen::VectorXd& displacement_mm) const;

  /// The support reactions: K u - loads at the constrained DOFs (the force each support
  /// exerts on the body), zero at the free DOFs.
  Eigen::VectorXd reactions_n(const Eigen::VectorXd& displacement_mm,
                              const Eigen::VectorXd& loads_n) const;

 private:
  TetMesh mesh_;
  std::vector<TetShape> shapes_;
  std::vector<ElementMatrix> element_k_;
  DofPartition partition_;
  FreeStiffnessAssembler assembler_;
  Eigen::SparseMatrix<double> k_;
  Eigen::SparseMatrix<double> k_ff_;
  // Tets with a constrained DOF: the only ones whose prescribed displacements load the free
  // DOFs.
  std::vector<int> constrained_tets_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt_;
};

/// Throws InputError("constraints", ...) unless `ldlt` factorised a positive definite matrix:
/// with too few constraints a rigid motion stays free and a pivot is (numerically) zero.
void check_positive_definite(const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>& ldlt);

}  // namespace hapvox::engine::fem
