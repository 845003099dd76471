#include "engine/fem/mesh_refinement.h"

#include <algorithm>
#include <limits>
#include <string>
#include <utility>

#include "engine/check.h"
#include "engine/errors.h"

namespace hapvox::engine::fem {
namespace {

// The Kuhn path of each tet of a cell: corner (x, y, z) in {0,1}^3 is x + 2y + 4z, and the
// path walks from corner 0 to corner 7 along one axis at a time (the axis orders in
// lexicographic order, as in regular_lattice).
constexpr std::array<std::array<int, 4>, 6> kKuhnPaths = {{
    {0, 1, 3, 7},  // x, y, z
    {0, 1, 5, 7},  // x, z, y
    {0, 2, 3, 7},  // y, x, z
    {0, 2, 6, 7},  // y, z, x
    {0, 4, 5, 7},  // z, x, y
    {0, 4, 6, 7},  // z, y, x
}};

// Passes of the closure before we call it a bug (theory: a few per refinement level).
constexpr int kMaxClosurePasses = 10000;

}  // namespace

BisectionMesh::BisectionMesh(const std::array<int, 3>& cells, const Eigen::Vector3d& origin_mm,
                             const Eigen::Vector3d& spacing_mm) {
  const std::string source = "bisection lattice";
  for (int axis = 0; axis < 3; ++axis) {
    if (cells[axis] < 1) {
      throw InputError(source, "needs at least 1 cell along axis " + std::to_string(axis));
    }
    if (!(spacing_mm[axis] > 0) || !std::isfinite(spacing_mm[axis])) {
      throw InputError(source, "spacing along axis " + std::to_string(axis) + " must be > 0");
    }
  }
  if (!origin_mm.allFinite()) throw InputError(source, "the origin is not finite");
  const auto [cx, cy, cz] = cells;
  const double tets = 6.0 * cx * cy * cz;
  if (tets > std::numeric_limits<std::int32_t>::max() / 64) {
    throw InputError(source, "too many tets (" + std::to_string(tets) + ")");
  }
  const int nx = cx + 1, ny = cy + 1, nz = cz + 1;
  auto index = [&](int i, int j, int k) { return i + nx * (j + ny * k); };
  positions_.resize(static_cast<std::size_t>(nx) * ny * nz);
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        positions_[index(i, j, k)] =
            origin_mm + spacing_mm.cwiseProduct(Eigen::Vector3d(double(i), double(j), double(k)));
      }
    }
  }
  tets_.reserve(static_cast<std::size_t>(tets));
  for (int k = 0; k < cz; ++k) {
    for (int j = 0; j < cy; ++j) {
      for (int i = 0; i < cx; ++i) {
        std::array<std::int32_t, 8> corner{};
        for (int c = 0; c < 8; ++c) corner[c] = index(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2));
        for (const auto& path : kKuhnPaths) {
          tets_.push_back({{corner[path[0]], corner[path[1]], corner[path[2]], corner[path[3]]}});
        }
      }
    }
  }
}

std::uint64_t BisectionMesh::edge_key(std::int32_t a, std::int32_t b) {
  if (a > b) std::swap(a, b);
  return static_cast<std::uint64_t>(a) << 32 | static_cast<std::uint32_t>(b);
}

std::int32_t BisectionMesh::midpoint(std::int32_t a, std::int32_t b) {
  const auto [it, inserted] = midpoints_.try_emplace(edge_key(a, b), vertex_count());
  if (inserted) {
    // Always from the lower index, so the midpoint's bits do not depend on which tet asked.
    const std::int32_t lo = std::min(a, b), hi = std::max(a, b);
    positions_.push_back(0.5 * (positions_[lo] + positions_[hi]));
  }
  return it->second;
}

bool BisectionMesh::has_split_edge(const BisectionTet& tet) const {
  for (int k = 0; k < 4; ++k) {
    for (int l = k + 1; l < 4; ++l) {
      if (midpoints_.contains(edge_key(tet.vertices[k], tet.vertices[l]))) return true;
    }
  }
  return false;
}

void BisectionMesh::bisect(std::size_t t) {
  // Maubach: z splits x0 - x_k; child 1 is x with x_k replaced by z, child 2 is
  // (x1, ..., x_k, z, x_{k+1}, ..., x_3); both get tag k - 1 (3 after 1).
  const BisectionTet parent = tets_[t];
  const int k = parent.tag;
  const std::int32_t z = midpoint(parent.vertices[0], parent.vertices[k]);
  BisectionTet first = parent, second = parent;
  first.vertices[k] = z;
  for (int i = 0; i < k; ++i) second.vertices[i] = parent.vertices[i + 1];
  second.vertices[k] = z;
  first.tag = second.tag = k > 1 ? k - 1 : 3;
  first.generation = second.generation = parent.generation + 1;
  tets_[t] = first;
  tets_.push_back(second);
}

int BisectionMesh::refine(const std::vector<char>& marked) {
  HAPVOX_CHECK_EQ(marked.size(), tets_.size());
  int bisections = 0;
  for (std::size_t t = 0; t < marked.size(); ++t) {
    if (marked[t]) {
      bisect(t);
      ++bisections;
    }
  }
  // Closure: a tet with a split edge is bisected (again, if its children still have one)
  // until a whole pass finds none. Newest-vertex bisection of the Kuhn lattice terminates.
  for (int pass = 0;; ++pass) {
    HAPVOX_CHECK_LT(pass, kMaxClosurePasses);
    int this_pass = 0;
    for (std::size_t t = 0; t < tets_.size(); ++t) {
      while (has_split_edge(tets_[t])) {
        bisect(t);
        ++this_pass;
      }
    }
    bisections += this_pass;
    if (this_pass == 0) break;
  }
  return bisections;
}

bool BisectionMesh::conforming() const {
  for (const BisectionTet& tet : tets_) {
    if (has_split_edge(tet)) return false;
  }
  return true;
}

TetMesh BisectionMesh::to_tet_mesh(std::int32_t label) const {
  TetMesh mesh;
  mesh.rest_mm.resize(3, vertex_count());
  for (int v = 0; v < vertex_count(); ++v) mesh.rest_mm.col(v) = positions_[v];
  mesh.tets.reserve(tets_.size());
  for (const BisectionTet& tet : tets_) {
    Tet out = tet.vertices;
    if (signed_volume_mm3(positions_[out[0]], positions_[out[1]], positions_[out[2]],
                          positions_[out[3]]) < 0) {
      std::swap(out[2], out[3]);
    }
    mesh.tets.push_back(out);
  }
  mesh.labels.assign(mesh.tets.size(), label);
  return mesh;
}

}  // namespace hapvox::engine::fem
