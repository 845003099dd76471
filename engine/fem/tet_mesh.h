#pragma once
// Tetrahedral meshes for the proxy-geometry FEM (Nakao): rest positions, tets, labels, the
// regular Kuhn lattice the adaptive mesh starts from, and the quality measures reported for
// any mesh (signed volumes, dihedral angles). Units: millimetres.

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace hapvox::engine::fem {

/// Four vertex indices, positively oriented: (v1-v0)·((v2-v0)×(v3-v0)) > 0.
using Tet = std::array<std::int32_t, 4>;
/// Three vertex indices, counter-clockwise seen from outside the mesh.
using Triangle = std::array<std::int32_t, 3>;

/// A tetrahedral mesh at rest.
struct TetMesh {
  /// Column v is vertex v's rest position (mm).
  Eigen::Matrix3Xd rest_mm;
  /// The elements; every one positively oriented.
  std::vector<Tet> tets;
  /// One label per tet (the region it belongs to; picks its material).
  std::vector<std::int32_t> labels;

  int vertex_count() const { return static_cast<int>(rest_mm.cols()); }
  int tet_count() const { return static_cast<int>(tets.size()); }
};

/// Throws InputError(source, ...) unless every tet names four distinct vertices in range, is
/// positively oriented with a non-zero volume, and has a label.
void validate(const TetMesh& mesh, const std::string& source);

/// The regular lattice of `vertices` = (n_x, n_y, n_z) vertices (each >= 2) spaced
/// `spacing_mm` apart from `origin_mm`, every cube cut into the 6 tets of the Kuhn
/// (Freudenthal) subdivision along its main diagonal. The same cut in every cube makes it
/// conforming; its tets have dihedral angles 45°, 60° and 90° only. Vertex (i, j, k) has
/// index i + n_x (j + n_y k); every tet gets `label`. Throws InputError on bad arguments.
TetMesh regular_lattice(const std::array<int, 3>& vertices, double spacing_mm,
                        const Eigen::Vector3d& origin_mm, std::int32_t label = 0);

/// Signed volume (mm^3) of the tet (a, b, c, d); positive when positively oriented.
double signed_volume_mm3(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                         const Eigen::Vector3d& c, const Eigen::Vector3d& d);

/// Gradients (1/mm) of the four barycentric coordinates of the tet (a, b, c, d), as columns.
/// Column k is normal to the face opposite vertex k, pointing into the tet. The tet must not
/// be degenerate.
Eigen::Matrix<double, 3, 4> barycentric_gradients_per_mm(const Eigen::Vector3d& a,
                                                         const Eigen::Vector3d& b,
                                                         const Eigen::Vector3d& c,
                                                         const Eigen::Vector3d& d);

/// The six interior dihedral angles (degrees) of the tet (a, b, c, d), one per edge.
std::array<double, 6> dihedral_angles_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c, const Eigen::Vector3d& d);

/// Quality of a mesh at rest, as reported for every mesh hapvox builds.
struct MeshQuality {
  double total_volume_mm3 = 0;
  double min_volume_mm3 = 0;
  double max_volume_mm3 = 0;
  /// Tets whose signed volume is <= 0.
  int inverted_tets = 0;
  double min_dihedral_deg = 0;
  double max_dihedral_deg = 0;
};
MeshQuality mesh_quality(const TetMesh& mesh);

/// Sum of the signed tet volumes (mm^3) with vertex v at positions_mm.col(v): the volume of
/// the deformed body while no tet is inverted.
double deformed_volume_mm3(const TetMesh& mesh, const Eigen::Matrix3Xd& positions_mm);

/// The faces that belong to one tet only (the mesh's surface), oriented outward, in a
/// deterministic order (by their sorted vertex indices).
std::vector<Triangle> boundary_faces(const TetMesh& mesh);

}  // namespace hapvox::engine::fem
