#include "engine/proxy/proxy_mesh.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <unordered_map>

#include "engine/errors.h"
#include "engine/fem/dofs.h"

namespace hapvox::engine::proxy {
namespace {

// Reference volume (mm^3) of each label: its voxels' cells, which tile the box the mesh spans.
std::map<std::int32_t, double> reference_volumes_mm3(const labels::LabelMap& map) {
  std::map<std::int32_t, double> volumes;
  const double voxel_mm3 = map.spacing_mm().prod();
  for (const auto& [label, count] : map.voxel_counts()) {
    volumes[label] = static_cast<double>(count) * voxel_mm3;
  }
  return volumes;
}

// The label of the voxel whose cell holds `p_mm`, the nearest voxel's on and beyond the box's
// faces: the mesher samples the box's faces, which belong to the outermost cells (at_world
// gives 0 on the upper faces, cells being half-open, which would cut a rim of background
// along them).
labels::Label label_in_box(const labels::LabelMap& map, const Vec3d& p_mm) {
  const Vec3d index = map.world_to_index(p_mm);
  Vec3i ijk;
  for (int a = 0; a < 3; ++a) {
    const double nearest = std::floor(index[a] + 0.5);
    ijk[a] = std::isfinite(nearest)
                 ? static_cast<int>(std::clamp(nearest, 0.0, double(map.dims()[a] - 1)))
                 : 0;
  }
  return map.at(ijk);
}

std::vector<fem::TetMaterial> tet_materials(const fem::TetMesh& mesh,
                                            const labels::Materials& materials) {
  std::vector<fem::TetMaterial> out;
  out.reserve(mesh.tets.size());
  // Each label's material once: Materials::find searches, once per tet it grew as tets
  // times materials.
  std::unordered_map<labels::Label, const labels::Material*> by_label;
  for (const labels::Material& m : materials.materials) by_label.emplace(m.label, &m);
  for (int t = 0; t < mesh.tet_count(); ++t) {
    const auto found = by_label.find(mesh.labels[t]);
    const labels::Material* m = found == by_label.end() ? nullptr : found->second;
    if (m == nullptr) {
      throw InputError(materials.source, "label " + std::to_string(mesh.labels[t]) +
                                             " has no material (tet " + std::to_string(t) + ")");
    }
    out.push_back({m->elastic.youngs_modulus_pa, m->elastic.poisson_ratio});
  }
  return out;
}

// classify_vertices for fixed labels and unlabelled boxes; a labelled box fixes only the
// vertices of its label's tets (a surface vertex is shared with the other side's tets).
std::vector<fem::VertexClass> vertex_classes(const fem::TetMesh& mesh,
                                             const labels::Materials& materials,
                                             const std::vector<labels::FixedBox>& boxes) {
  std::vector<Eigen::AlignedBox3d> plain;
  for (const labels::FixedBox& box : boxes) {
    if (!box.label) plain.emplace_back(box.min_mm, box.max_mm);
  }
  std::vector<fem::VertexClass> classes =
      fem::classify_vertices(mesh, materials.fixed_labels(), plain);
  for (const labels::FixedBox& box : boxes) {
    if (!box.label) continue;
    for (int t = 0; t < mesh.tet_count(); ++t) {
      if (mesh.labels[t] != *box.label) continue;
      for (std::int32_t v : mesh.tets[t]) {
        if (box.contains(mesh.rest_mm.col(v), mesh.labels[t]))
          classes[v] = fem::VertexClass::kFixed;
      }
    }
  }
  return classes;
}

}  // namespace

Eigen::AlignedBox3d voxel_box(const labels::LabelMap& labels) {
  const Vec3d a = labels.index_to_world(Vec3d::Constant(-0.5));
  const Vec3d b = labels.index_to_world(labels.dims().cast<double>() - Vec3d::Constant(0.5));
  return {a.cwiseMin(b), a.cwiseMax(b)};
}

ProxyMesh build_proxy_mesh(const labels::LabelMap& labels, const labels::Materials& materials,
                           const ProxyMeshOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  labels::check_labels_have_materials(labels, materials);
  const std::vector<labels::FixedBox> boxes = labels::resolve_fixed_regions(materials, labels);

  fem::ConformingMeshOptions mesh_options;
  mesh_options.box_mm = voxel_box(labels);
  mesh_options.coarse_spacing_mm = options.coarse_spacing_mm > 0
                                       ? options.coarse_spacing_mm
                                       : mesh_options.box_mm.sizes().minCoeff() / 8.0;
  mesh_options.boundary_levels = options.boundary_levels;
  mesh_options.tool_region = options.tool_region;
  mesh_options.tool_levels = options.tool_levels;
  const fem::LabelFunction label_at = [&labels](const Eigen::Vector3d& p_mm) {
    return label_in_box(labels, p_mm);
  };
  fem::ConformingMesh built =
      fem::build_conforming_mesh(mesh_options, label_at, reference_volumes_mm3(labels));

  ProxyMesh proxy;
  proxy.materials = tet_materials(built.mesh, materials);
  proxy.vertex_classes = vertex_classes(built.mesh, materials, boxes);
  proxy.mesh = std::move(built.mesh);
  proxy.report = std::move(built.report);
  proxy.materials_source = materials.source;
  proxy.report.build_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return proxy;
}

int fixed_vertex_count(const ProxyMesh& proxy) {
  return static_cast<int>(std::count(proxy.vertex_classes.begin(), proxy.vertex_classes.end(),
                                     fem::VertexClass::kFixed));
}

std::vector<int> fixed_dofs(const ProxyMesh& proxy) {
  std::vector<int> dofs;
  for (int v = 0; v < static_cast<int>(proxy.vertex_classes.size()); ++v) {
    if (proxy.vertex_classes[v] != fem::VertexClass::kFixed) continue;
    for (int axis = 0; axis < 3; ++axis) dofs.push_back(fem::dof_index(v, axis));
  }
  return dofs;
}

}  // namespace hapvox::engine::proxy
