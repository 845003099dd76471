#include "engine/fem/conforming_mesh.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <span>
#include <string>
#include <utility>

#include "engine/check.h"
#include "engine/errors.h"
#include "engine/fem/mesh_refinement.h"
#include "engine/fem/tet_stencils.h"

namespace hapvox::engine::fem {
namespace {

constexpr int kMaxLevels = 8;

void validate_options(const ConformingMeshOptions& options) {
  const std::string source = "proxy mesh";
  const Eigen::AlignedBox3d& box = options.box_mm;
  if (!box.min().allFinite() || !box.max().allFinite() || !(box.sizes().array() > 0).all()) {
    throw InputError(source, "the box must be finite and have a positive size on every axis");
  }
  if (!(options.coarse_spacing_mm > 0) || !std::isfinite(options.coarse_spacing_mm)) {
    throw InputError(
        source, "coarse spacing " + std::to_string(options.coarse_spacing_mm) + " mm must be > 0");
  }
  for (const auto& [name, levels] : {std::pair{"boundary_levels", options.boundary_levels},
                                     std::pair{"tool_levels", options.tool_levels}}) {
    if (levels < 0 || levels > kMaxLevels) {
      throw InputError(source, std::string(name) + " " + std::to_string(levels) +
                                   " must lie in [0, " + std::to_string(kMaxLevels) + "]");
    }
  }
  if (!(options.warp_fraction >= 0 && options.warp_fraction <= 0.5)) {
    throw InputError(source, "warp_fraction must lie in [0, 0.5]");
  }
  if (!(options.min_warped_dihedral_deg >= 0 && options.min_warped_dihedral_deg < 60)) {
    throw InputError(source, "min_warped_dihedral_deg must lie in [0, 60)");
  }
  if (options.cut_iterations < 1 || options.cut_iterations > 60) {
    throw InputError(source, "cut_iterations must lie in [1, 60]");
  }
  if (options.tool_region) {
    if (const auto* sphere = std::get_if<Sphere>(&*options.tool_region)) {
      if (!sphere->center_mm.allFinite() || !(sphere->radius_mm > 0)) {
        throw InputError(source, "the tool sphere needs a finite centre and a radius > 0");
      }
    }
  }
}

Eigen::AlignedBox3d bounds(const BisectionMesh& mesh, const BisectionTet& tet) {
  Eigen::AlignedBox3d box;
  for (std::int32_t v : tet.vertices) box.extend(mesh.positions_mm()[v]);
  return box;
}

bool touches(const Region& region, const Eigen::AlignedBox3d& box) {
  if (const auto* sphere = std::get_if<Sphere>(&region)) {
    return box.squaredExteriorDistance(sphere->center_mm) <= sphere->radius_mm * sphere->radius_mm;
  }
  return box.intersects(std::get<Eigen::AlignedBox3d>(region));
}

// Whether the label differs between the tet's vertices, edge midpoints and centroid.
bool crosses_boundary(const BisectionMesh& mesh, const BisectionTet& tet,
                      const LabelFunction& label) {
  std::array<Eigen::Vector3d, 4> x;
  for (int k = 0; k < 4; ++k) x[k] = mesh.positions_mm()[tet.vertices[k]];
  const std::int32_t first = label(x[0]);
  for (int k = 1; k < 4; ++k) {
    if (label(x[k]) != first) return true;
  }
  for (int k = 0; k < 4; ++k) {
    for (int l = k + 1; l < 4; ++l) {
      if (label(0.5 * (x[k] + x[l])) != first) return true;
    }
  }
  return label(0.25 * (x[0] + x[1] + x[2] + x[3])) != first;
}

// Refines the lattice until every tet has reached the generation its place asks for.
void refine(BisectionMesh& mesh, const ConformingMeshOptions& options, const LabelFunction& label) {
  // Generation 3L is the Kuhn lattice of spacing h / 2^L; two more bisections split its cell
  // and face diagonals, so that no edge is longer than h / 2^L.
  const int boundary_target = 3 * options.boundary_levels + 2;
  const int tool_target = options.tool_region ? 3 * options.tool_levels : 0;
  const int deepest = std::max(boundary_target, tool_target);
  std::vector<char> marked;
  for (;;) {
    marked.assign(mesh.tet_count(), 0);
    bool any = false;
    for (int t = 0; t < mesh.tet_count(); ++t) {
      const BisectionTet& tet = mesh.tets()[t];
      if (tet.generation >= deepest) continue;
      if (tet.generation < tool_target && touches(*options.tool_region, bounds(mesh, tet))) {
        marked[t] = 1;
      } else if (tet.generation < boundary_target && crosses_boundary(mesh, tet, label)) {
        marked[t] = 1;
      }
      any = any || marked[t];
    }
    if (!any) return;
    mesh.refine(marked);
  }
}

struct Edge {
  std::int32_t a = 0, b = 0;  // a < b
  // Where the label changes, as a fraction of the way from a to b; valid while `cut`.
  double t = 0;
  bool cut = false;
  std::int32_t cut_vertex = -1;
};

// Compressed incidence lists: items_[offsets_[i] .. offsets_[i+1]) belong to i.
struct Incidence {
  std::vector<std::int32_t> offsets, items;
  template <class Each>
  Incidence(int count, int total, Each&& each) : offsets(count + 1, 0), items(total) {
    each([&](int i, int) { ++offsets[i + 1]; });
    for (int i = 0; i < count; ++i) offsets[i + 1] += offsets[i];
    std::vector<std::int32_t> fill(offsets.begin(), offsets.end() - 1);
    each([&](int i, int item) { items[fill[i]++] = item; });
  }
  std::span<const std::int32_t> of(int i) const {
    return {items.data() + offsets[i], items.data() + offsets[i + 1]};
  }
};

bool dihedrals_within(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                      const Eigen::Vector3d& d, double sign, double min_deg) {
  if (!(sign * signed_volume_mm3(a, b, c, d) > 0)) return false;
  for (double angle : dihedral_angles_deg(a, b, c, d)) {
    if (angle < min_deg || angle > 180.0 - min_deg) return false;
  }
  return true;
}

}  // namespace

void measure_mesh(const TetMesh& mesh, const LabelFunction& label,
                  const std::map<std::int32_t, double>& reference_volumes_mm3,
                  ConformingMeshReport& report) {
  report.vertex_count = mesh.vertex_count();
  report.tet_count = mesh.tet_count();
  report.quality = mesh_quality(mesh);
  report.volume_mm3_by_label.clear();
  report.centroid_label_mismatches = 0;
  for (int t = 0; t < mesh.tet_count(); ++t) {
    const Tet& tet = mesh.tets[t];
    const Eigen::Vector3d a = mesh.rest_mm.col(tet[0]), b = mesh.rest_mm.col(tet[1]),
                          c = mesh.rest_mm.col(tet[2]), d = mesh.rest_mm.col(tet[3]);
    report.volume_mm3_by_label[mesh.labels[t]] += signed_volume_mm3(a, b, c, d);
    if (label(0.25 * (a + b + c + d)) != mesh.labels[t]) ++report.centroid_label_mismatches;
  }
  report.relative_volume_error_by_label.clear();
  for (const auto& [id, reference] : reference_volumes_mm3) {
    const auto found = report.volume_mm3_by_label.find(id);
    const double volume = found == report.volume_mm3_by_label.end() ? 0.0 : found->second;
    report.relative_volume_error_by_label[id] = (volume - reference) / reference;
  }
}

ConformingMesh build_conforming_mesh(const ConformingMeshOptions& options,
                                     const LabelFunction& label,
                                     const std::map<std::int32_t, double>& reference_volumes_mm3) {
  const auto start = std::chrono::steady_clock::now();
  validate_options(options);
  ConformingMesh result;
  ConformingMeshReport& report = result.report;

  // 1-2. The lattice, refined.
  const Eigen::Vector3d size = options.box_mm.sizes();
  std::array<int, 3> cells{};
  Eigen::Vector3d spacing;
  for (int axis = 0; axis < 3; ++axis) {
    cells[axis] =
        std::max(1, static_cast<int>(std::lround(size[axis] / options.coarse_spacing_mm)));
    spacing[axis] = size[axis] / cells[axis];
  }
  BisectionMesh lattice(cells, options.box_mm.min(), spacing);
  refine(lattice, options, label);
  report.lattice_vertex_count = lattice.vertex_count();
  report.lattice_tet_count = lattice.tet_count();
  std::vector<Eigen::Vector3d> positions = lattice.positions_mm();
  const std::vector<BisectionTet>& tets = lattice.tets();
  const int n_vertices = lattice.vertex_count();
  const int n_tets = lattice.tet_count();

  // 3. Labels at the vertices, edges and their cut points.
  std::vector<std::int32_t> vertex_label(n_vertices);
  for (int v = 0; v < n_vertices; ++v) vertex_label[v] = label(positions[v]);
  std::vector<std::uint64_t> keys;
  keys.reserve(static_cast<std::size_t>(n_tets) * 6);
  for (const BisectionTet& tet : tets) {
    for (int k = 0; k < 4; ++k) {
      for (int l = k + 1; l < 4; ++l) keys.push_back(edge_key(tet.vertices[k], tet.vertices[l]));
    }
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  auto edge_of = [&](std::int32_t a, std::int32_t b) {
    return static_cast<int>(std::lower_bound(keys.begin(), keys.end(), edge_key(a, b)) -
                            keys.begin());
  };
  std::vector<Edge> edges(keys.size());
  for (std::size_t e = 0; e < keys.size(); ++e) {
    Edge& edge = edges[e];
    edge.a = static_cast<std::int32_t>(keys[e] >> 32);
    edge.b = static_cast<std::int32_t>(keys[e] & 0xffffffffu);
    const std::int32_t from = vertex_label[edge.a];
    if (from == vertex_label[edge.b]) continue;
    const Eigen::Vector3d xa = positions[edge.a], xb = positions[edge.b];
    double lo = 0, hi = 1;
    for (int i = 0; i < options.cut_iterations; ++i) {
      const double mid = 0.5 * (lo + hi);
      (label(xa + mid * (xb - xa)) == from ? lo : hi) = mid;
    }
    edge.t = 0.5 * (lo + hi);
    edge.cut = true;
  }

  // 4. Warping.
  const Incidence vertex_edges(n_vertices, static_cast<int>(2 * edges.size()), [&](auto add) {
    for (std::size_t e = 0; e < edges.size(); ++e) {
      add(edges[e].a, static_cast<int>(e));
      add(edges[e].b, static_cast<int>(e));
    }
  });
  const Incidence vertex_tets(n_vertices, 4 * n_tets, [&](auto add) {
    for (int t = 0; t < n_tets; ++t) {
      for (std::int32_t v : tets[t].vertices) add(v, t);
    }
  });
  // The lattice's orientation of each tet (its vertices are in Maubach order).
  std::vector<double> orientation(n_tets);
  for (int t = 0; t < n_tets; ++t) {
    const auto& v = tets[t].vertices;
    orientation[t] =
        signed_volume_mm3(positions[v[0]], positions[v[1]], positions[v[2]], positions[v[3]]) > 0
            ? 1.0
            : -1.0;
  }
  // The box faces each vertex lies on (a bit per face): a vertex warps only along edges that
  // stay on all of its faces, so the box keeps its shape.
  // The lattice's far corner, computed as the lattice computes it (bit for bit; midpoints
  // of edges on a face keep its coordinate exactly).
  const Eigen::Vector3d far_corner =
      options.box_mm.min() +
      spacing.cwiseProduct(Eigen::Vector3d(double(cells[0]), double(cells[1]), double(cells[2])));
  std::vector<std::uint8_t> box_faces(n_vertices, 0);
  for (int v = 0; v < n_vertices; ++v) {
    for (int axis = 0; axis < 3; ++axis) {
      if (positions[v][axis] == options.box_mm.min()[axis]) box_faces[v] |= 1u << (2 * axis);
      if (positions[v][axis] == far_corner[axis]) {
        box_faces[v] |= 1u << (2 * axis + 1);
      }
    }
  }
  std::vector<char> on_surface(n_vertices, 0);
  std::vector<std::pair<double, int>> candidates;
  for (int v = 0; v < n_vertices; ++v) {
    candidates.clear();
    for (int e : vertex_edges.of(v)) {
      if (!edges[e].cut) continue;
      const std::int32_t other = edges[e].a == v ? edges[e].b : edges[e].a;
      if ((box_faces[v] & ~box_faces[other]) != 0) continue;
      const double fraction = edges[e].a == v ? edges[e].t : 1.0 - edges[e].t;
      if (fraction < options.warp_fraction) candidates.emplace_back(fraction, e);
    }
    if (candidates.empty()) continue;
    std::sort(candidates.begin(), candidates.end());
    const Eigen::Vector3d home = positions[v];
    bool warped = false;
    for (const auto& [fraction, e] : candidates) {
      const Edge& edge = edges[e];
      positions[v] = positions[edge.a] + edge.t * (positions[edge.b] - positions[edge.a]);
      warped = true;
      for (int t : vertex_tets.of(v)) {
        const auto& x = tets[t].vertices;
        if (!dihedrals_within(positions[x[0]], positions[x[1]], positions[x[2]], positions[x[3]],
                              orientation[t], options.min_warped_dihedral_deg)) {
          warped = false;
          break;
        }
      }
      if (warped) break;
    }
    if (!warped) {
      positions[v] = home;
      ++report.refused_warps;
      continue;
    }
    ++report.warped_vertices;
    on_surface[v] = 1;
    for (int e : vertex_edges.of(v)) edges[e].cut = false;
  }

  // Cut points become vertices after the lattice's, in edge order. One still closer than
  // warp_fraction to a vertex (whose warp was refused or would have left the box's face) is
  // pushed to warp_fraction from it: the boundary moves a little rather than a sliver being
  // made. So every cut lies within [warp_fraction, 1 - warp_fraction] of its edge.
  const double floor = options.warp_fraction;
  for (Edge& edge : edges) {
    if (!edge.cut) continue;
    if (edge.t < floor || edge.t > 1 - floor) {
      edge.t = std::clamp(edge.t, floor, 1 - floor);
      ++report.clamped_cuts;
    }
    edge.cut_vertex = static_cast<std::int32_t>(positions.size());
    positions.push_back(positions[edge.a] + edge.t * (positions[edge.b] - positions[edge.a]));
    ++report.cut_points;
  }
  TetMesh& mesh = result.mesh;
  mesh.rest_mm.resize(3, static_cast<Eigen::Index>(positions.size()));
  for (std::size_t v = 0; v < positions.size(); ++v) mesh.rest_mm.col(v) = positions[v];

  // 5. Cutting.
  TetEmitter emit(positions, mesh);
  auto cut = [&](std::int32_t a, std::int32_t b) {
    const Edge& edge = edges[edge_of(a, b)];
    HAPVOX_CHECK(edge.cut);
    return edge.cut_vertex;
  };
  for (int t = 0; t < n_tets; ++t) {
    const auto& x = tets[t].vertices;
    std::vector<std::int32_t> surface, side_a, side_b;
    std::int32_t label_a = 0, label_b = 0;
    bool third = false;
    for (std::int32_t v : x) {
      if (on_surface[v]) {
        surface.push_back(v);
      } else if (side_a.empty() || vertex_label[v] == label_a) {
        label_a = vertex_label[v];
        side_a.push_back(v);
      } else if (side_b.empty() || vertex_label[v] == label_b) {
        label_b = vertex_label[v];
        side_b.push_back(v);
      } else {
        third = true;
      }
    }
    if (third || side_a.empty()) {
      // Three labels, or every vertex on a surface: kept whole (step 6 labels it).
      report.unresolved_tets += third;
      emit.tet(x[0], x[1], x[2], x[3], label_a);
      continue;
    }
    if (side_b.empty()) {
      emit.tet(x[0], x[1], x[2], x[3], label_a);
      continue;
    }
    ++report.cut_tets;
    // Make side a the smaller one.
    if (side_a.size() > side_b.size()) {
      std::swap(side_a, side_b);
      std::swap(label_a, label_b);
    }
    const std::int32_t p = side_a[0];
    if (surface.empty() && side_a.size() == 1) {
      const std::int32_t c0 = cut(p, side_b[0]), c1 = cut(p, side_b[1]), c2 = cut(p, side_b[2]);
      emit.tet(p, c0, c1, c2, label_a);
      emit.prism({c0, c1, c2}, {side_b[0], side_b[1], side_b[2]}, label_b);
    } else if (surface.empty()) {
      const std::int32_t q = side_a[1], r = side_b[0], s = side_b[1];
      const std::int32_t pr = cut(p, r), ps = cut(p, s), qr = cut(q, r), qs = cut(q, s);
      emit.prism({p, pr, ps}, {q, qr, qs}, label_a);
      emit.prism({r, pr, qr}, {s, ps, qs}, label_b);
    } else if (surface.size() == 1) {
      const std::int32_t z = surface[0], r = side_b[0], s = side_b[1];
      const std::int32_t pr = cut(p, r), ps = cut(p, s);
      emit.tet(z, p, pr, ps, label_a);
      emit.pyramid(z, {r, s, ps, pr}, label_b);
    } else {
      const std::int32_t r = side_b[0], pr = cut(p, r);
      emit.tet(surface[0], surface[1], p, pr, label_a);
      emit.tet(surface[0], surface[1], r, pr, label_b);
    }
  }
  report.dropped_degenerate_tets = emit.degenerate();

  // 6. Every tet takes the label at its centroid. A tet whose vertices all lie on one side of
  // a curved boundary (or on it) can still reach across it between them: its centroid says
  // which region most of it lies in.
  for (int t = 0; t < mesh.tet_count(); ++t) {
    const Tet& tet = mesh.tets[t];
    const std::int32_t at_centroid = label(
        0.25 * (positions[tet[0]] + positions[tet[1]] + positions[tet[2]] + positions[tet[3]]));
    if (at_centroid != mesh.labels[t]) {
      ++report.relabelled_tets;
      mesh.labels[t] = at_centroid;
    }
  }
  measure_mesh(mesh, label, reference_volumes_mm3, report);
  report.build_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

std::vector<VertexClass> classify_vertices(const TetMesh& mesh,
                                           const std::set<std::int32_t>& fixed_labels,
                                           const std::vector<Eigen::AlignedBox3d>& fixed_boxes) {
  std::vector<VertexClass> classes(mesh.vertex_count(), VertexClass::kFree);
  for (int t = 0; t < mesh.tet_count(); ++t) {
    if (!fixed_labels.contains(mesh.labels[t])) continue;
    for (std::int32_t v : mesh.tets[t]) classes[v] = VertexClass::kFixed;
  }
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    for (const Eigen::AlignedBox3d& box : fixed_boxes) {
      if (box.contains(mesh.rest_mm.col(v))) classes[v] = VertexClass::kFixed;
    }
  }
  return classes;
}

}  // namespace hapvox::engine::fem
