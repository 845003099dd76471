#pragma once
// Moving a per-vertex field from one tet mesh to another over the same body: each vertex of
// the new mesh is located in a tet of the old one (its barycentric weights there), and the
// field is interpolated linearly. What carries the deformation over when the proxy mesh is
// rebuilt in the middle of a run (the labels changed; haptics/fem_remesh.h). Linear fields
// come through exactly; the point location is the expensive half and is done once, on the
// thread that builds the new mesh, so that applying it on the FEM thread is one pass over
// the new vertices.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "engine/fem/tet_mesh.h"

namespace hapvox::engine::fem {

/// A point located in a mesh: the tet's four vertices and the point's barycentric weights
/// (they sum to 1; all >= 0 inside the tet).
struct TetPoint {
  std::int32_t tet = -1;
  std::array<std::int32_t, 4> vertices{};
  std::array<double, 4> weights{};
};

/// Locates every column of `points_mm` in `mesh`: the tet whose smallest barycentric weight
/// at the point is largest, which is a tet containing the point when one does. A point
/// outside the mesh gets the tet it is nearest to lying in, and weights that extrapolate
/// linearly (some negative). Uses a uniform grid of tet bounding boxes, so the cost is about
/// linear in the number of points and tets. The mesh must have at least one tet.
std::vector<TetPoint> locate_points(const TetMesh& mesh, const Eigen::Matrix3Xd& points_mm);

/// The field (3 values per vertex of the mesh the points were located in) interpolated at
/// the located points: 3 values per point.
Eigen::VectorXd interpolate_vector_field(const std::vector<TetPoint>& points,
                                         const Eigen::VectorXd& field);

}  // namespace hapvox::engine::fem
