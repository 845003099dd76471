#pragma once
// Incisions in the proxy mesh (Nakao et al. 2010, §3.3, Fig. 3 and 7; the subdivision after
// Bielser et al.): the mesh is split along a cut surface, elements subdivided and the vertices
// on the cut duplicated, one copy for each side, so that the FEM can pull the two faces apart
// (two face-to-face constraint surfaces) and the renderer shows the opening.
//
// 1. The side of every vertex: its signed distance from the plane through its nearest point on
//    the cut surface across that point's angle-weighted pseudo-normal (Baerentzen & Aanaes
//    2005), so that beyond the surface's border the split continues along the border's own
//    plane. A vertex closer than a tenth of its shortest edge is counted that far away on its
//    side (no sliver pieces).
// 2. Every edge whose ends lie on different sides gets a crossing vertex where the linear
//    interpolant of the signed distance is zero, and every tet with such edges is split along
//    the plane through them (a tet and a prism, or two prisms; the stencils of
//    tet_stencils.h, so neighbours agree and the mesh stays conforming). Every piece lies on
//    one side. Planar cuts are reproduced exactly.
// 3. A crossing vertex within a quarter of its edge of the cut surface itself is on the cut:
//    it is duplicated, the pieces on the - side taking the copy. Crossings beyond the cut's
//    border (the split continues there along the border's plane) stay single: the crack ends
//    there, and the material on both sides stays joined.
//
// A pure function of its inputs; units mm.

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "engine/fem/tet_mesh.h"

namespace hapvox::engine::fem {

/// A cut surface: triangles (world mm) whose counter-clockwise normals point to the + side.
/// Triangles that share a corner share it bit for bit (it is how their edges are found).
struct CutSurface {
  std::vector<std::array<Eigen::Vector3d, 3>> triangles_mm;
};

/// The surface the polyline sweeps along `sweep_mm`: the polyline's point p moves to
/// p + sweep_mm; two triangles per segment, normals along segment x sweep. Throws
/// InputError(source, ...) for fewer than two points, a non-finite coordinate, a zero-length
/// segment, or a sweep that is zero or parallel to a segment.
CutSurface swept_polyline(const std::vector<Eigen::Vector3d>& polyline_mm,
                          const Eigen::Vector3d& sweep_mm, const std::string& source);

/// A vertex of an incised mesh: the point (1 - t) a + t b of the mesh that was cut (a == b,
/// t = 0 for a vertex it had).
struct SplitVertex {
  std::int32_t a = 0, b = 0;
  double t = 0;
};

/// The two copies of a vertex on the cut: `plus` in the tets on the + side, `minus` in those
/// on the - side, and the cut's unit normal there (towards +).
struct CutPair {
  std::int32_t plus = 0, minus = 0;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
};

struct IncisionReport {
  int split_tets = 0;         // tets of the cut mesh that were subdivided
  int crossing_vertices = 0;  // vertices made on crossed edges (before duplication)
  int cut_pairs = 0;          // crossing vertices duplicated (on the cut)
  int nudged_vertices = 0;    // vertices counted a tenth of an edge off the cut (step 1)
};

struct IncisedMesh {
  TetMesh mesh;                          // the mesh's vertices first, then crossings, then copies
  std::vector<SplitVertex> origin;       // per vertex
  std::vector<std::int32_t> parent_tet;  // per tet: the tet of the cut mesh it is a piece of
  std::vector<CutPair> pairs;            // in crossing order
  IncisionReport report;
};

/// Splits `mesh` along `cut` (steps 1-3 above). Throws InputError(source, ...) when the cut
/// has no triangle, a degenerate or non-finite one, or opens no face of the mesh.
IncisedMesh incise(const TetMesh& mesh, const CutSurface& cut, const std::string& source);

/// The displacements that open the cut by `width_mm`: each pair's plus copy moved by
/// +width/2 along its normal, its minus copy by -width/2, as (DOF, mm) in pair order.
std::vector<std::pair<int, double>> opening_displacements(const IncisedMesh& incised,
                                                          double width_mm);

}  // namespace hapvox::engine::fem
