#pragma once
// The proxy model of Nakao's direct volume manipulation: a volume's labels turned into an
// adaptive, label-conforming tet mesh (engine/fem/conforming_mesh.h) with one material per
// tet from the materials file (engine/labels/materials.h) and a class per vertex (fixed by a
// fixed label or a fixed region, else free). What the FEM stages (haptics/fem_model.h), the
// session writer and `hapvox mesh` take. Units: mm, Pa.

#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "engine/fem/conforming_mesh.h"
#include "engine/fem/element.h"
#include "engine/fem/tet_mesh.h"
#include "engine/labels/label_map.h"
#include "engine/labels/materials.h"

namespace hapvox::engine::proxy {

/// A built proxy mesh: the mesh, per-tet materials, per-vertex classes and the report.
struct ProxyMesh {
  fem::TetMesh mesh;                             // rest positions (world mm), tets, labels
  std::vector<fem::TetMaterial> materials;       // one per tet, from its label
  std::vector<fem::VertexClass> vertex_classes;  // kFixed or kFree (kConstrained at run time)
  fem::ConformingMeshReport report;              // counts, dihedral range, volume errors
  std::string materials_source;                  // the materials file, as named in errors
  /// Displacements (DOF, mm) the FEM holds its vertices at: an incision's opening
  /// (engine/proxy/incised_proxy.h). Empty for a mesh as built.
  std::vector<std::pair<int, double>> prescribed_mm;
};

/// How the mesh is built over the label map.
struct ProxyMeshOptions {
  /// The lattice spacing; 0 picks one: the box's shortest side / 8.
  double coarse_spacing_mm = 0.0;
  int boundary_levels = 2;
  std::optional<fem::Region> tool_region;
  int tool_levels = 1;
};

/// Builds the proxy mesh of `labels` (every label present must have a material, else
/// InputError(materials.source, ...)). The mesh spans the voxels' cells (voxel_box), so its
/// outer faces lie where the voxel model's nominal surface does for material that fills the
/// volume to its edge (the density crossing 1/2 half a voxel beyond the last centre), and the
/// label function is the label of the voxel whose cell holds the point (the nearest voxel's
/// on the box's faces), so a boundary between labels lies on the cells' faces, half-way
/// between voxel centres, where the voxel model's nominal surface between a full and an empty
/// voxel lies. Reference volumes per label are the voxel counts times the voxel volume.
/// Vertex classes: every vertex of a tet of a fixed label, every vertex in a fixed region
/// without a label, and in a region with a label every vertex of that label's tets in it, is
/// kFixed. A tet whose label has no material is InputError(materials.source, ...). Bad
/// options: InputError("proxy mesh", ...) from build_conforming_mesh.
ProxyMesh build_proxy_mesh(const labels::LabelMap& labels, const labels::Materials& materials,
                           const ProxyMeshOptions& options = {});

/// The box the mesh covers: the voxels' cells, from the first voxel's centre less half a voxel
/// to the last's plus half a voxel (world mm).
Eigen::AlignedBox3d voxel_box(const labels::LabelMap& labels);

/// The number of kFixed vertices.
int fixed_vertex_count(const ProxyMesh& proxy);

/// The DOFs of the fixed vertices (3 per vertex, in vertex order): the FEM's Dirichlet set.
std::vector<int> fixed_dofs(const ProxyMesh& proxy);

}  // namespace hapvox::engine::proxy
