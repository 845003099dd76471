#include "engine/fem/tet_mesh.h"

#include <Eigen/Geometry>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "engine/errors.h"

namespace hapvox::engine::fem {
namespace {

// The faces of a positively oriented tet (v0, v1, v2, v3), face k opposite vertex k, each
// ordered so that its normal (right-hand rule) points out of the tet.
constexpr std::array<std::array<int, 3>, 4> kOutwardFaces = {{
    {1, 2, 3},
    {0, 3, 2},
    {0, 1, 3},
    {0, 2, 1},
}};

// The Kuhn subdivision of the unit cube whose corner (x, y, z) in {0,1}^3 is numbered
// x + 2y + 4z: one tet per order of the three axes, walking from corner 0 to corner 7 one
// axis at a time. Odd axis orders give negatively oriented walks; their last two vertices
// are swapped so that every tet is positive.
constexpr std::array<std::array<int, 4>, 6> kKuhnCubeTets = {{
    {0, 1, 3, 7},  // x, y, z (even)
    {0, 1, 7, 5},  // x, z, y (odd, swapped)
    {0, 2, 7, 3},  // y, x, z (odd, swapped)
    {0, 2, 6, 7},  // y, z, x (even)
    {0, 4, 5, 7},  // z, x, y (even)
    {0, 4, 7, 6},  // z, y, x (odd, swapped)
}};

std::string tet_name(int t) { return "tet " + std::to_string(t); }

}  // namespace

void validate(const TetMesh& mesh, const std::string& source) {
  if (mesh.labels.size() != mesh.tets.size()) {
    throw InputError(source, std::to_string(mesh.tets.size()) + " tets but " +
                                 std::to_string(mesh.labels.size()) + " labels");
  }
  if (!mesh.rest_mm.allFinite()) throw InputError(source, "a vertex position is not finite");
  const int n = mesh.vertex_count();
  for (int t = 0; t < mesh.tet_count(); ++t) {
    const Tet& tet = mesh.tets[t];
    for (int k = 0; k < 4; ++k) {
      if (tet[k] < 0 || tet[k] >= n) {
        throw InputError(source, tet_name(t) + " names vertex " + std::to_string(tet[k]) + " of " +
                                     std::to_string(n));
      }
      for (int l = 0; l < k; ++l) {
        if (tet[k] == tet[l]) {
          throw InputError(source,
                           tet_name(t) + " names vertex " + std::to_string(tet[k]) + " twice");
        }
      }
    }
    const double volume = signed_volume_mm3(mesh.rest_mm.col(tet[0]), mesh.rest_mm.col(tet[1]),
                                            mesh.rest_mm.col(tet[2]), mesh.rest_mm.col(tet[3]));
    if (!(volume > 0)) {
      throw InputError(source, tet_name(t) + " has volume " + std::to_string(volume) +
                                   " mm^3; tets must be positively oriented");
    }
  }
}

TetMesh regular_lattice(const std::array<int, 3>& vertices, double spacing_mm,
                        const Eigen::Vector3d& origin_mm, std::int32_t label) {
  const std::string source = "lattice";
  for (int axis = 0; axis < 3; ++axis) {
    if (vertices[axis] < 2) {
      throw InputError(source, "needs at least 2 vertices along each axis, got " +
                                   std::to_string(vertices[axis]) + " along axis " +
                                   std::to_string(axis));
    }
  }
  if (!(spacing_mm > 0) || !std::isfinite(spacing_mm)) {
    throw InputError(source, "spacing " + std::to_string(spacing_mm) + " mm must be > 0");
  }
  if (!origin_mm.allFinite()) throw InputError(source, "the origin is not finite");
  const auto [nx, ny, nz] = vertices;
  // Tet indices are int32: 6 tets per cube must fit.
  const double tets = 6.0 * (nx - 1.0) * (ny - 1.0) * (nz - 1.0);
  if (tets > std::numeric_limits<std::int32_t>::max()) {
    throw InputError(source, "too many tets (" + std::to_string(tets) + ")");
  }

  TetMesh mesh;
  mesh.rest_mm.resize(3, static_cast<Eigen::Index>(nx) * ny * nz);
  // Captured by value: clang 14 (the fuzz build's) cannot capture structured bindings.
  auto index = [nx = nx, ny = ny](int i, int j, int k) { return i + nx * (j + ny * k); };
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        // Multiplying the integer index (not accumulating) keeps every coordinate exact in
        // the index and identical across builds.
        mesh.rest_mm.col(index(i, j, k)) =
            origin_mm + spacing_mm * Eigen::Vector3d(double(i), double(j), double(k));
      }
    }
  }
  mesh.tets.reserve(static_cast<std::size_t>(tets));
  for (int k = 0; k + 1 < nz; ++k) {
    for (int j = 0; j + 1 < ny; ++j) {
      for (int i = 0; i + 1 < nx; ++i) {
        std::array<std::int32_t, 8> corner{};
        for (int c = 0; c < 8; ++c) corner[c] = index(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2));
        for (const auto& cube_tet : kKuhnCubeTets) {
          mesh.tets.push_back(
              {corner[cube_tet[0]], corner[cube_tet[1]], corner[cube_tet[2]], corner[cube_tet[3]]});
        }
      }
    }
  }
  mesh.labels.assign(mesh.tets.size(), label);
  return mesh;
}

double signed_volume_mm3(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                         const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
  return (b - a).dot((c - a).cross(d - a)) / 6.0;
}

Eigen::Matrix<double, 3, 4> barycentric_gradients_per_mm(const Eigen::Vector3d& a,
                                                         const Eigen::Vector3d& b,
                                                         const Eigen::Vector3d& c,
                                                         const Eigen::Vector3d& d) {
  // x = a + D (l1, l2, l3) with D = [b-a, c-a, d-a], so grad l_k (k = 1..3) is row k of
  // D^-1, and l0 = 1 - l1 - l2 - l3.
  Eigen::Matrix3d edges;
  edges << b - a, c - a, d - a;
  const Eigen::Matrix3d inverse = edges.inverse();
  Eigen::Matrix<double, 3, 4> gradients;
  gradients.rightCols<3>() = inverse.transpose();
  gradients.col(0) = -gradients.rightCols<3>().rowwise().sum();
  return gradients;
}

std::array<double, 6> dihedral_angles_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
  // The inward normals of faces k and l make the angle pi - theta, where theta is the
  // dihedral angle at the edge the two faces share.
  const Eigen::Matrix<double, 3, 4> g = barycentric_gradients_per_mm(a, b, c, d);
  std::array<double, 6> angles{};
  int e = 0;
  for (int k = 0; k < 4; ++k) {
    for (int l = k + 1; l < 4; ++l) {
      const double cosine = -g.col(k).dot(g.col(l)) / (g.col(k).norm() * g.col(l).norm());
      angles[e++] = std::acos(std::clamp(cosine, -1.0, 1.0)) * 180.0 / std::numbers::pi;
    }
  }
  return angles;
}

MeshQuality mesh_quality(const TetMesh& mesh) {
  MeshQuality quality;
  quality.min_volume_mm3 = std::numeric_limits<double>::infinity();
  quality.max_volume_mm3 = -std::numeric_limits<double>::infinity();
  quality.min_dihedral_deg = std::numeric_limits<double>::infinity();
  quality.max_dihedral_deg = -std::numeric_limits<double>::infinity();
  for (const Tet& tet : mesh.tets) {
    const Eigen::Vector3d a = mesh.rest_mm.col(tet[0]), b = mesh.rest_mm.col(tet[1]),
                          c = mesh.rest_mm.col(tet[2]), d = mesh.rest_mm.col(tet[3]);
    const double volume = signed_volume_mm3(a, b, c, d);
    quality.total_volume_mm3 += volume;
    quality.min_volume_mm3 = std::min(quality.min_volume_mm3, volume);
    quality.max_volume_mm3 = std::max(quality.max_volume_mm3, volume);
    if (volume <= 0) {
      ++quality.inverted_tets;
      continue;  // a degenerate tet has no meaningful angles
    }
    for (double angle : dihedral_angles_deg(a, b, c, d)) {
      quality.min_dihedral_deg = std::min(quality.min_dihedral_deg, angle);
      quality.max_dihedral_deg = std::max(quality.max_dihedral_deg, angle);
    }
  }
  return quality;
}

double deformed_volume_mm3(const TetMesh& mesh, const Eigen::Matrix3Xd& positions_mm) {
  double volume = 0;
  for (const Tet& tet : mesh.tets) {
    volume += signed_volume_mm3(positions_mm.col(tet[0]), positions_mm.col(tet[1]),
                                positions_mm.col(tet[2]), positions_mm.col(tet[3]));
  }
  return volume;
}

std::vector<Triangle> boundary_faces(const TetMesh& mesh) {
  // Sorting the faces by their sorted vertex triple puts the two copies of an interior face
  // side by side; a face without a twin is on the surface.
  struct Face {
    std::array<std::int32_t, 3> key;
    Triangle oriented;
  };
  std::vector<Face> faces;
  faces.reserve(mesh.tets.size() * 4);
  for (const Tet& tet : mesh.tets) {
    for (const auto& local : kOutwardFaces) {
      const Triangle oriented = {tet[local[0]], tet[local[1]], tet[local[2]]};
      std::array<std::int32_t, 3> key = oriented;
      std::sort(key.begin(), key.end());
      faces.push_back({key, oriented});
    }
  }
  std::sort(faces.begin(), faces.end(), [](const Face& x, const Face& y) { return x.key < y.key; });
  std::vector<Triangle> surface;
  for (std::size_t i = 0; i < faces.size();) {
    std::size_t j = i + 1;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    if (j - i == 1) surface.push_back(faces[i].oriented);
    i = j;
  }
  return surface;
}

}  // namespace hapvox::engine::fem
