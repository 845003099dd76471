#pragma once
// Splitting tets into tets along points on their edges: the stencils the label-conforming
// mesh (conforming_mesh.h) and the incision (incision.h) cut with. Every quadrilateral is split
// by the diagonal through its lowest-numbered vertex, which both tets sharing it agree on, so
// a mesh cut by per-edge points stays conforming (Dompierre et al. 1999).

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "engine/fem/tet_mesh.h"

namespace hapvox::engine::fem {

/// A key for the undirected edge (a, b): the same for (b, a).
inline std::uint64_t edge_key(std::int32_t a, std::int32_t b) {
  if (a > b) std::swap(a, b);
  return static_cast<std::uint64_t>(a) << 32 | static_cast<std::uint32_t>(b);
}

/// Appends positively oriented tets (and their labels) to a mesh, from the vertex positions
/// `positions` (indices into it). A tet of zero volume is left out and counted.
class TetEmitter {
 public:
  TetEmitter(const std::vector<Eigen::Vector3d>& positions, TetMesh& out)
      : positions_(positions), out_(out) {}

  int degenerate() const { return degenerate_; }

  void tet(std::int32_t a, std::int32_t b, std::int32_t c, std::int32_t d, std::int32_t label) {
    Tet tet = {a, b, c, d};
    const double volume =
        signed_volume_mm3(positions_[a], positions_[b], positions_[c], positions_[d]);
    if (volume == 0) {
      ++degenerate_;
      return;
    }
    if (volume < 0) std::swap(tet[2], tet[3]);
    out_.tets.push_back(tet);
    out_.labels.push_back(label);
  }

  /// The pyramid with apex `apex` over the quadrilateral q0 q1 q2 q3 (in cyclic order).
  void pyramid(std::int32_t apex, const std::array<std::int32_t, 4>& q, std::int32_t label) {
    const auto lowest = std::min_element(q.begin(), q.end()) - q.begin();
    const int s = lowest % 2;  // the diagonal q_s - q_{s+2}
    tet(apex, q[s], q[s + 1], q[s + 2], label);
    tet(apex, q[s], q[s + 2], q[(s + 3) % 4], label);
  }

  /// The prism with triangles a0 a1 a2 and b0 b1 b2 and lateral edges a_i - b_i (Dompierre et
  /// al. 1999: split at its lowest-numbered vertex, then the remaining pyramid).
  void prism(std::array<std::int32_t, 3> a, std::array<std::int32_t, 3> b, std::int32_t label) {
    const std::int32_t lowest_a = *std::min_element(a.begin(), a.end());
    const std::int32_t lowest_b = *std::min_element(b.begin(), b.end());
    if (lowest_b < lowest_a) std::swap(a, b);
    while (a[0] != std::min(lowest_a, lowest_b)) {
      std::rotate(a.begin(), a.begin() + 1, a.end());
      std::rotate(b.begin(), b.begin() + 1, b.end());
    }
    tet(a[0], b[0], b[1], b[2], label);
    pyramid(a[0], {a[1], a[2], b[2], b[1]}, label);
  }

 private:
  const std::vector<Eigen::Vector3d>& positions_;
  TetMesh& out_;
  int degenerate_ = 0;
};

}  // namespace hapvox::engine::fem
