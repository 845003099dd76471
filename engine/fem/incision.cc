#include "engine/fem/incision.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>

#include "engine/check.h"
#include "engine/errors.h"
#include "engine/fem/tet_stencils.h"

namespace hapvox::engine::fem {
namespace {

using Eigen::Vector3d;

// A crossing within this fraction of its edge's length from the cut surface is on the cut.
constexpr double kOnCutFraction = 0.25;
// A vertex nearer the cut than this fraction of its shortest edge counts as that far away.
constexpr double kNudgeFraction = 0.1;

// The cut surface with shared corners welded, face normals and pseudo-normals (Baerentzen &
// Aanaes 2005: a face's normal on its interior, the sum of the adjacent faces' normals on an
// edge, their angle-weighted sum at a corner), which give the side of any point from its
// nearest point on the surface.
class SignedSurface {
 public:
  SignedSurface(const CutSurface& cut, const std::string& source) {
    if (cut.triangles_mm.empty()) throw InputError(source, "the cut surface has no triangle");
    std::map<std::tuple<double, double, double>, std::int32_t> index_of;
    for (std::size_t f = 0; f < cut.triangles_mm.size(); ++f) {
      std::array<std::int32_t, 3> face{};
      for (int k = 0; k < 3; ++k) {
        const Vector3d& p = cut.triangles_mm[f][k];
        if (!p.allFinite()) {
          throw InputError(source, "triangle " + std::to_string(f) + " has a non-finite corner");
        }
        const auto [it, added] = index_of.try_emplace(std::make_tuple(p.x(), p.y(), p.z()),
                                                      static_cast<std::int32_t>(corners_.size()));
        if (added) corners_.push_back(p);
        face[k] = it->second;
      }
      const Vector3d& a = corners_[face[0]];
      const Vector3d normal = (corners_[face[1]] - a).cross(corners_[face[2]] - a);
      const double scale = std::max(
          {(corners_[face[1]] - a).squaredNorm(), (corners_[face[2]] - a).squaredNorm(), 1e-300});
      if (!(normal.norm() > 1e-9 * scale)) {
        throw InputError(source, "triangle " + std::to_string(f) + " has no area");
      }
      faces_.push_back(face);
      face_normals_.push_back(normal.normalized());
    }
    corner_normals_.assign(corners_.size(), Vector3d::Zero());
    for (std::size_t f = 0; f < faces_.size(); ++f) {
      const auto& face = faces_[f];
      for (int k = 0; k < 3; ++k) {
        const Vector3d u = corners_[face[(k + 1) % 3]] - corners_[face[k]];
        const Vector3d v = corners_[face[(k + 2) % 3]] - corners_[face[k]];
        const double angle = std::atan2(u.cross(v).norm(), u.dot(v));
        corner_normals_[face[k]] += angle * face_normals_[f];
        // (A Vector3d a map default-constructs is uninitialised: start from zero.)
        edge_normals_.try_emplace(edge_key(face[k], face[(k + 1) % 3]), Vector3d::Zero())
            .first->second += face_normals_[f];
      }
    }
  }

  struct Nearest {
    double distance_mm = std::numeric_limits<double>::infinity();
    Vector3d point = Vector3d::Zero();
    Vector3d pseudo_normal = Vector3d::Zero();
  };

  Nearest nearest(const Vector3d& p) const {
    Nearest best;
    for (std::size_t f = 0; f < faces_.size(); ++f) {
      Vector3d normal;
      const Vector3d q = closest_on_face(f, p, normal);
      const double d = (p - q).norm();
      if (d < best.distance_mm) best = Nearest{d, q, normal};
    }
    return best;
  }

  /// The distance from the plane through the nearest point across its pseudo-normal: the
  /// distance on the surface's side, and beyond its border the distance from the border's
  /// plane, so that the zero set continues the surface flat and a linear interpolant between
  /// two points finds it exactly on a flat piece. + on the side the normals point to.
  double signed_distance(const Vector3d& p) const {
    const Nearest n = nearest(p);
    return (p - n.point).dot(n.pseudo_normal.normalized());
  }

 private:
  // The closest point of face f to p (Ericson, Real-Time Collision Detection, 5.1.5) and the
  // pseudo-normal of the feature it lies on.
  Vector3d closest_on_face(std::size_t f, const Vector3d& p, Vector3d& normal) const {
    const auto& face = faces_[f];
    const Vector3d &a = corners_[face[0]], &b = corners_[face[1]], &c = corners_[face[2]];
    const auto edge = [&](int i, int j) { return edge_normals_.at(edge_key(face[i], face[j])); };
    const Vector3d ab = b - a, ac = c - a, ap = p - a;
    const double d1 = ab.dot(ap), d2 = ac.dot(ap);
    if (d1 <= 0 && d2 <= 0) {
      normal = corner_normals_[face[0]];
      return a;
    }
    const Vector3d bp = p - b;
    const double d3 = ab.dot(bp), d4 = ac.dot(bp);
    if (d3 >= 0 && d4 <= d3) {
      normal = corner_normals_[face[1]];
      return b;
    }
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
      normal = edge(0, 1);
      return a + d1 / (d1 - d3) * ab;
    }
    const Vector3d cp = p - c;
    const double d5 = ab.dot(cp), d6 = ac.dot(cp);
    if (d6 >= 0 && d5 <= d6) {
      normal = corner_normals_[face[2]];
      return c;
    }
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
      normal = edge(0, 2);
      return a + d2 / (d2 - d6) * ac;
    }
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
      normal = edge(1, 2);
      return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
    }
    const double denominator = 1.0 / (va + vb + vc);
    normal = face_normals_[f];
    return a + ab * (vb * denominator) + ac * (vc * denominator);
  }

  std::vector<Vector3d> corners_;
  std::vector<std::array<std::int32_t, 3>> faces_;
  std::vector<Vector3d> face_normals_, corner_normals_;
  std::map<std::uint64_t, Vector3d> edge_normals_;
};

}  // namespace

CutSurface swept_polyline(const std::vector<Vector3d>& polyline_mm, const Vector3d& sweep_mm,
                          const std::string& source) {
  if (polyline_mm.size() < 2) throw InputError(source, "the polyline needs at least two points");
  if (!sweep_mm.allFinite() || sweep_mm.norm() == 0.0) {
    throw InputError(source, "the sweep must be a finite, non-zero vector");
  }
  CutSurface cut;
  for (std::size_t i = 0; i < polyline_mm.size(); ++i) {
    if (!polyline_mm[i].allFinite()) {
      throw InputError(source, "polyline point " + std::to_string(i) + " is not finite");
    }
    if (i == 0) continue;
    const Vector3d& p = polyline_mm[i - 1];
    const Vector3d& q = polyline_mm[i];
    const Vector3d segment = q - p;
    if (segment.norm() == 0.0) {
      throw InputError(source, "polyline points " + std::to_string(i - 1) + " and " +
                                   std::to_string(i) + " coincide");
    }
    if (segment.cross(sweep_mm).norm() <= 1e-9 * segment.norm() * sweep_mm.norm()) {
      throw InputError(source,
                       "the sweep is parallel to polyline segment " + std::to_string(i - 1));
    }
    cut.triangles_mm.push_back({p, q, Vector3d(q + sweep_mm)});
    cut.triangles_mm.push_back({p, Vector3d(q + sweep_mm), Vector3d(p + sweep_mm)});
  }
  return cut;
}

IncisedMesh incise(const TetMesh& mesh, const CutSurface& cut, const std::string& source) {
  const SignedSurface surface(cut, source);
  const int n = mesh.vertex_count();
  IncisedMesh out;

  // The edges, and each vertex's shortest one.
  std::vector<std::uint64_t> keys;
  keys.reserve(mesh.tets.size() * 6);
  for (const Tet& tet : mesh.tets) {
    for (int k = 0; k < 4; ++k) {
      for (int l = k + 1; l < 4; ++l) keys.push_back(edge_key(tet[k], tet[l]));
    }
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  const auto ends = [](std::uint64_t key) {
    return std::pair<std::int32_t, std::int32_t>(static_cast<std::int32_t>(key >> 32),
                                                 static_cast<std::int32_t>(key & 0xffffffffu));
  };
  std::vector<double> shortest_mm(n, std::numeric_limits<double>::infinity());
  for (const std::uint64_t key : keys) {
    const auto [a, b] = ends(key);
    const double length = (mesh.rest_mm.col(a) - mesh.rest_mm.col(b)).norm();
    shortest_mm[a] = std::min(shortest_mm[a], length);
    shortest_mm[b] = std::min(shortest_mm[b], length);
  }

  // 1. Sides.
  std::vector<double> phi(n);
  for (int v = 0; v < n; ++v) {
    phi[v] = surface.signed_distance(mesh.rest_mm.col(v));
    const double floor = kNudgeFraction * shortest_mm[v];
    if (std::abs(phi[v]) < floor) {
      phi[v] = phi[v] < 0 ? -floor : floor;
      ++out.report.nudged_vertices;
    }
  }

  // 2. Crossing vertices, in edge order, and whether each lies on the cut.
  std::vector<Vector3d> positions(n);
  for (int v = 0; v < n; ++v) positions[v] = mesh.rest_mm.col(v);
  out.origin.resize(n);
  for (int v = 0; v < n; ++v) out.origin[v] = SplitVertex{v, v, 0.0};
  std::map<std::uint64_t, std::int32_t> crossing;
  std::vector<std::int32_t> on_cut;  // crossing vertices on the cut, in order
  std::vector<Vector3d> normals;
  for (const std::uint64_t key : keys) {
    const auto [a, b] = ends(key);
    if ((phi[a] < 0) == (phi[b] < 0)) continue;
    const double t = phi[a] / (phi[a] - phi[b]);
    const Vector3d x = (1.0 - t) * positions[a] + t * positions[b];
    const auto c = static_cast<std::int32_t>(positions.size());
    crossing.emplace(key, c);
    positions.push_back(x);
    out.origin.push_back(SplitVertex{a, b, t});
    const SignedSurface::Nearest near = surface.nearest(x);
    if (near.distance_mm <= kOnCutFraction * (positions[a] - positions[b]).norm()) {
      on_cut.push_back(c);
      normals.push_back(near.pseudo_normal.normalized());
    }
  }
  out.report.crossing_vertices = static_cast<int>(crossing.size());
  if (on_cut.empty()) {
    throw InputError(source, "the cut crosses no element of the mesh");
  }

  // Split every tet with crossed edges; every piece lies on one side.
  TetMesh& result = out.mesh;
  TetEmitter emit(positions, result);
  const auto cross = [&](std::int32_t a, std::int32_t b) { return crossing.at(edge_key(a, b)); };
  for (int t = 0; t < mesh.tet_count(); ++t) {
    const Tet& x = mesh.tets[t];
    const std::int32_t label = mesh.labels[t];
    const std::size_t before = result.tets.size();
    std::vector<std::int32_t> plus, minus;
    for (const std::int32_t v : x) (phi[v] < 0 ? minus : plus).push_back(v);
    if (plus.empty() || minus.empty()) {
      emit.tet(x[0], x[1], x[2], x[3], label);
    } else {
      ++out.report.split_tets;
      std::vector<std::int32_t>& a = plus.size() <= minus.size() ? plus : minus;
      std::vector<std::int32_t>& b = plus.size() <= minus.size() ? minus : plus;
      const std::int32_t p = a[0];
      if (a.size() == 1) {
        const std::int32_t c0 = cross(p, b[0]), c1 = cross(p, b[1]), c2 = cross(p, b[2]);
        emit.tet(p, c0, c1, c2, label);
        emit.prism({c0, c1, c2}, {b[0], b[1], b[2]}, label);
      } else {
        const std::int32_t q = a[1], r = b[0], s = b[1];
        const std::int32_t pr = cross(p, r), ps = cross(p, s), qr = cross(q, r), qs = cross(q, s);
        emit.prism({p, pr, ps}, {q, qr, qs}, label);
        emit.prism({r, pr, qr}, {s, ps, qs}, label);
      }
    }
    out.parent_tet.resize(result.tets.size(), t);
    HAPVOX_CHECK(result.tets.size() > before);
  }
  HAPVOX_CHECK_EQ(emit.degenerate(), 0);

  // 3. The crossings on the cut get a copy for the - side.
  std::vector<std::int32_t> minus_copy(positions.size(), -1);
  for (std::size_t i = 0; i < on_cut.size(); ++i) {
    const std::int32_t c = on_cut[i];
    const auto copy = static_cast<std::int32_t>(positions.size());
    minus_copy[c] = copy;
    positions.push_back(positions[c]);
    out.origin.push_back(out.origin[c]);
    out.pairs.push_back(CutPair{c, copy, normals[i]});
  }
  out.report.cut_pairs = static_cast<int>(out.pairs.size());
  for (Tet& tet : result.tets) {
    // The piece's side: that of its vertices from the cut mesh (every piece has one).
    const auto original =
        std::find_if(tet.begin(), tet.end(), [n](std::int32_t v) { return v < n; });
    HAPVOX_CHECK(original != tet.end());
    if (phi[*original] >= 0) continue;
    for (std::int32_t& v : tet) {
      if (v >= n && minus_copy[v] >= 0) v = minus_copy[v];
    }
  }
  result.rest_mm.resize(3, static_cast<Eigen::Index>(positions.size()));
  for (std::size_t v = 0; v < positions.size(); ++v) result.rest_mm.col(v) = positions[v];
  return out;
}

std::vector<std::pair<int, double>> opening_displacements(const IncisedMesh& incised,
                                                          double width_mm) {
  std::vector<std::pair<int, double>> out;
  out.reserve(6 * incised.pairs.size());
  for (const CutPair& pair : incised.pairs) {
    for (int axis = 0; axis < 3; ++axis) {
      out.emplace_back(3 * pair.plus + axis, 0.5 * width_mm * pair.normal[axis]);
    }
    for (int axis = 0; axis < 3; ++axis) {
      out.emplace_back(3 * pair.minus + axis, -0.5 * width_mm * pair.normal[axis]);
    }
  }
  return out;
}

}  // namespace hapvox::engine::fem
