#pragma once
// Small strain of a displaced tet mesh, per tet and averaged per label: what Nakao's Fig. 5
// compares between spheres of different stiffness (`hapvox info` on a FEM session, and
// scripts/fig5.sh). A constant-strain tet's displacement gradient is exact:
// grad u = sum_a u_a g_a^T with g_a its barycentric gradients, and eps = (grad u + grad u^T)/2.

#include <Eigen/Core>

#include <cstdint>
#include <map>

#include "engine/fem/tet_mesh.h"

namespace hapvox::engine::fem {

/// The small-strain tensor (dimensionless) of tet `t` with vertex v displaced by
/// displacement_mm.segment<3>(3 v).
Eigen::Matrix3d tet_strain(const TetMesh& mesh, int t, const Eigen::VectorXd& displacement_mm);

/// The equivalent (von Mises) strain sqrt(2/3 e:e) of the deviatoric part e of `strain`:
/// a uniaxial strain eps at nu = 0.5 gives |eps|; zero for a pure dilatation.
double equivalent_strain(const Eigen::Matrix3d& strain);

/// The Frobenius norm sqrt(eps:eps) of the strain: zero only for a rigid (infinitesimal)
/// motion, dilatation included in what it counts.
double strain_norm(const Eigen::Matrix3d& strain);

/// One label's volume-weighted means over its tets.
struct LabelStrain {
  int tet_count = 0;
  double volume_mm3 = 0;
  double mean_strain_norm = 0;        // sum V_t |eps_t| / sum V_t
  double mean_equivalent_strain = 0;  // sum V_t eps_eq,t / sum V_t
  double max_strain_norm = 0;
};

/// The mean strains of every label present, from rest volumes. Throws InputError("fem
/// displacement", ...) when the displacement does not have 3 entries per vertex.
std::map<std::int32_t, LabelStrain> mean_strain_by_label(const TetMesh& mesh,
                                                         const Eigen::VectorXd& displacement_mm);

}  // namespace hapvox::engine::fem
