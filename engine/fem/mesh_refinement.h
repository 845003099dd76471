#pragma once
// Local refinement of the Kuhn lattice by newest-vertex bisection (Maubach 1995, Traxler
// 1997), with a closure that bisects neighbours until no tet has a vertex in the middle of
// one of its edges: the refined mesh is conforming (no hanging vertices).
//
// Quality, proven: Maubach bisection of a Kuhn tet makes, after three generations, Kuhn tets
// of half the size; so every descendant is similar to one of three tets (generation mod 3),
// and on cubic cells every dihedral angle lies in the range those three tets span: 45° to
// 120° (kBisectionMinDihedralDeg, kBisectionMaxDihedralDeg; the tests reach both ends).
// Units: millimetres.

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "engine/fem/tet_mesh.h"

namespace hapvox::engine::fem {

/// The dihedral range of every tet bisection can make from Kuhn tets of a cubic lattice.
inline constexpr double kBisectionMinDihedralDeg = 45.0;
inline constexpr double kBisectionMaxDihedralDeg = 120.0;

/// A tet of a bisection hierarchy. `vertices` are in Maubach order x0..x3: the next
/// bisection splits the edge x0 - x_tag. Its orientation is not fixed.
struct BisectionTet {
  std::array<std::int32_t, 4> vertices{};
  std::int32_t tag = 3;
  /// Bisections since the lattice; every 3 halve the edge lengths.
  std::int32_t generation = 0;
};

class BisectionMesh {
 public:
  /// The Kuhn lattice of `cells` (each >= 1) cells of size `spacing_mm` (per axis) from
  /// `origin_mm`, every cell cut into 6 tets along its main diagonal, each tagged 3.
  BisectionMesh(const std::array<int, 3>& cells, const Eigen::Vector3d& origin_mm,
                const Eigen::Vector3d& spacing_mm);

  const std::vector<Eigen::Vector3d>& positions_mm() const { return positions_; }
  const std::vector<BisectionTet>& tets() const { return tets_; }
  int vertex_count() const { return static_cast<int>(positions_.size()); }
  int tet_count() const { return static_cast<int>(tets_.size()); }

  /// Bisects every tet t with marked[t] (marked has tet_count() entries), then as many
  /// others as conformity needs. Tet t's first child keeps index t, later children are
  /// appended, so the order depends on the input only. Returns the number of bisections.
  int refine(const std::vector<char>& marked);

  /// True when no tet has the midpoint of one of its edges as a vertex of the mesh.
  bool conforming() const;

  /// The mesh with every tet positively oriented and labelled `label`.
  TetMesh to_tet_mesh(std::int32_t label = 0) const;

 private:
  static std::uint64_t edge_key(std::int32_t a, std::int32_t b);
  std::int32_t midpoint(std::int32_t a, std::int32_t b);
  bool has_split_edge(const BisectionTet& tet) const;
  void bisect(std::size_t t);

  std::vector<Eigen::Vector3d> positions_;
  std::vector<BisectionTet> tets_;
  // Split edges (by edge_key) and their midpoint vertex. Only looked up, never iterated, so
  // its order cannot leak into the mesh.
  std::unordered_map<std::uint64_t, std::int32_t> midpoints_;
};

}  // namespace hapvox::engine::fem
