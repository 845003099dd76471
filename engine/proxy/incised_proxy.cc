#include "engine/proxy/incised_proxy.h"

#include <cmath>
#include <map>

#include "engine/errors.h"

namespace hapvox::engine::proxy {

ProxyMesh incise(const ProxyMesh& proxy, const fem::CutSurface& cut, double width_mm,
                 const std::string& source) {
  if (!(std::isfinite(width_mm) && width_mm > 0.0)) {
    throw InputError(source, "the incision's width must be > 0 mm");
  }
  fem::IncisedMesh incised = fem::incise(proxy.mesh, cut, source);
  ProxyMesh out;
  out.materials_source = proxy.materials_source;
  for (const std::int32_t parent : incised.parent_tet)
    out.materials.push_back(proxy.materials[parent]);
  out.vertex_classes.reserve(incised.origin.size());
  for (const fem::SplitVertex& o : incised.origin) {
    const bool fixed = proxy.vertex_classes[o.a] == fem::VertexClass::kFixed &&
                       proxy.vertex_classes[o.b] == fem::VertexClass::kFixed;
    out.vertex_classes.push_back(fixed ? fem::VertexClass::kFixed : fem::VertexClass::kFree);
  }
  // Earlier prescriptions carried to the vertices on their vertices' edges (interpolated),
  // then the opening's.
  std::map<int, double> prescribed;
  if (!proxy.prescribed_mm.empty()) {
    std::map<int, double> before(proxy.prescribed_mm.begin(), proxy.prescribed_mm.end());
    for (std::size_t v = 0; v < incised.origin.size(); ++v) {
      const fem::SplitVertex& o = incised.origin[v];
      for (int axis = 0; axis < 3; ++axis) {
        const auto a = before.find(3 * o.a + axis), b = before.find(3 * o.b + axis);
        if (a == before.end() || b == before.end()) continue;
        prescribed[3 * static_cast<int>(v) + axis] = (1.0 - o.t) * a->second + o.t * b->second;
      }
    }
  }
  for (const auto& [dof, mm] : fem::opening_displacements(incised, width_mm)) prescribed[dof] = mm;
  out.prescribed_mm.assign(prescribed.begin(), prescribed.end());
  out.mesh = std::move(incised.mesh);
  out.report = proxy.report;
  out.report.vertex_count = out.mesh.vertex_count();
  out.report.tet_count = out.mesh.tet_count();
  out.report.quality = fem::mesh_quality(out.mesh);
  return out;
}

}  // namespace hapvox::engine::proxy
