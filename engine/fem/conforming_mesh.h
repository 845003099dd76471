#pragma once
// The adaptive, label-conforming proxy mesh (Nakao §3.1-3.2): a coarse Kuhn lattice over the
// volume's box, refined by bisection near label boundaries and near the region the tool
// works in, then made to conform to the label boundaries by warping and cutting.
//
// 1. Lattice: the box cut into cells of about `coarse_spacing_mm` (per axis: the extent
//    divided by a whole number of cells), 6 Kuhn tets per cell.
// 2. Refinement (mesh_refinement.h): a tet is bisected while it is younger than its target
//    generation: 3 x boundary_levels + 2 where the label differs between any of 11 samples
//    (vertices, edge midpoints, centroid), so that no edge there is longer than
//    coarse_spacing / 2^boundary_levels; 3 x tool_levels where it touches the tool region
//    (spacing / 2^tool_levels). The closure keeps the mesh conforming; every tet has dihedral
//    angles of 45°-120°.
// 3. Cut points: on each edge whose end labels differ, the label change is found by
//    bisection of the label function (cut_iterations halvings).
// 4. Warping (as in isosurface stuffing, Labelle & Shewchuk 2007): in vertex order, a vertex
//    with a cut point closer than warp_fraction x the edge's length moves onto the nearest
//    one and becomes a surface vertex; the cut points on its edges are dropped. A warp that
//    would take an incident tet outside [min_warped_dihedral_deg, 180° - that] or invert it,
//    or move a vertex off a face of the box, is not made.
// 5. Cutting: a tet whose non-surface vertices carry two labels is split along its cut
//    points into tets of one label each (tet, pyramid and prism stencils; every quadrilateral
//    split by the diagonal through its lowest-numbered vertex, so neighbours agree and the
//    mesh stays conforming). A tet with three or more labels is kept whole and counted
//    (unresolved_tets).
// 6. Each tet takes the label at its centroid. That is the side it was cut to except where a
//    tet with its vertices on one side (or on the boundary) reaches across a curved boundary
//    far enough for its centroid to lie beyond (relabelled_tets).
//
// Quality. Steps 1-2 are proven (45°-120°). Warping and cutting are not: the dihedral range
// kConformingMinDihedralDeg - kConformingMaxDihedralDeg (8°-165°) is a measured margin, not a
// proof: with the default options four spheres give 14.0°-151.5° and 60 random sets of three
// spheres (some cut by the box) 10.0°-162.4°. The tests enforce it on four spheres and on 12
// random sets, and every mesh's report carries its own range. The warp guard keeps warped lattice
// tets within [min_warped_dihedral_deg, 180° - that]; every cut lies at least warp_fraction of its
// edge from both ends (a cut left closer, where a warp was refused or would have moved a vertex off
// the box's face, is pushed there: clamped_cuts).
//
// The build is a pure function of its inputs (the same inputs give a bit-identical mesh) and
// may run on any thread. Units: millimetres.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <variant>
#include <vector>

#include "engine/fem/tet_mesh.h"

namespace hapvox::engine::fem {

/// The dihedral range measured (not proven) for conforming meshes with the default options.
inline constexpr double kConformingMinDihedralDeg = 8.0;
inline constexpr double kConformingMaxDihedralDeg = 165.0;

/// The label at a world position (mm).
using LabelFunction = std::function<std::int32_t(const Eigen::Vector3d& world_mm)>;

struct Sphere {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
  double radius_mm = 0;
};
/// A region to refine in: an axis-aligned box or a sphere (mm).
using Region = std::variant<Eigen::AlignedBox3d, Sphere>;

struct ConformingMeshOptions {
  /// The volume's box (world mm).
  Eigen::AlignedBox3d box_mm;
  double coarse_spacing_mm = 0;
  /// Halvings of the spacing at label boundaries: no edge there is longer than
  /// coarse_spacing_mm / 2^boundary_levels.
  int boundary_levels = 2;
  /// The region the tool works in, refined tool_levels halvings.
  std::optional<Region> tool_region;
  int tool_levels = 1;
  /// A vertex closer than this fraction of an edge's length to the edge's cut point moves
  /// onto it (0 turns warping off; at most 0.5).
  double warp_fraction = 0.38;
  /// A warp is refused when an incident tet would get a dihedral angle below this or above
  /// 180° minus this.
  double min_warped_dihedral_deg = 15.0;
  /// Halvings of an edge when looking for its cut point (40: 1e-12 of the edge).
  int cut_iterations = 40;
};

/// The quality and label volumes of a mesh, as reported for every proxy mesh.
struct ConformingMeshReport {
  int vertex_count = 0;
  int tet_count = 0;
  /// The refined lattice before warping and cutting.
  int lattice_vertex_count = 0;
  int lattice_tet_count = 0;
  int warped_vertices = 0;
  int refused_warps = 0;
  int cut_points = 0;
  /// Cut points moved away from an unwarped vertex they were too close to.
  int clamped_cuts = 0;
  int cut_tets = 0;
  /// Tets with three or more labels at their vertices, kept whole.
  int unresolved_tets = 0;
  /// Tets whose centroid lies beyond the boundary they were cut along (step 6).
  int relabelled_tets = 0;
  /// Tets whose label differs from the label function at their centroid.
  int centroid_label_mismatches = 0;
  /// Pieces of a cut with zero volume, left out (a gap in the mesh; none expected).
  int dropped_degenerate_tets = 0;
  /// Volumes, inverted tets and the dihedral range.
  MeshQuality quality;
  std::map<std::int32_t, double> volume_mm3_by_label;
  /// (volume - reference) / reference for each label a reference volume was given for.
  std::map<std::int32_t, double> relative_volume_error_by_label;
  /// Wall-clock time of the build (not part of the mesh; varies run to run).
  double build_seconds = 0;
};

struct ConformingMesh {
  TetMesh mesh;
  ConformingMeshReport report;
};

/// Builds the mesh. Throws InputError("proxy mesh", ...) on bad options (an empty or
/// non-finite box, spacing <= 0, levels < 0 or > 8, warp_fraction outside [0, 0.5]).
/// `reference_volumes_mm3` (label -> volume) fills relative_volume_error_by_label.
ConformingMesh build_conforming_mesh(
    const ConformingMeshOptions& options, const LabelFunction& label,
    const std::map<std::int32_t, double>& reference_volumes_mm3 = {});

/// Fills the quality and volume fields of `report` (counts, dihedral range, volumes, errors,
/// centroid mismatches) from the mesh; leaves the build statistics alone.
void measure_mesh(const TetMesh& mesh, const LabelFunction& label,
                  const std::map<std::int32_t, double>& reference_volumes_mm3,
                  ConformingMeshReport& report);

enum class VertexClass : std::uint8_t {
  kFree = 0,
  /// Held by the tool (set by the interaction, not here).
  kConstrained = 1,
  kFixed = 2,
};

/// kFixed for every vertex of a tet whose label is in `fixed_labels` and every vertex inside
/// (or on) one of `fixed_boxes`; kFree otherwise.
std::vector<VertexClass> classify_vertices(const TetMesh& mesh,
                                           const std::set<std::int32_t>& fixed_labels,
                                           const std::vector<Eigen::AlignedBox3d>& fixed_boxes);

}  // namespace hapvox::engine::fem
