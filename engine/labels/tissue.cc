#include "engine/labels/tissue.h"

#include <unordered_map>
#include <utility>
#include <vector>

#include "engine/io/grid_build.h"

namespace hapvox::engine::labels {

TissueVolume tissue_volume(const LabelMap& map, const Materials& materials,
                           const TissueMaterial& fallback) {
  check_labels_have_materials(map, materials, /*background_needs_material=*/false);
  std::vector<TissueMaterial> rows = {fallback};
  std::unordered_map<Label, std::int32_t> slot_of;
  std::unordered_map<Label, float> density_of;
  for (const Material& m : materials.materials) {
    slot_of[m.label] = static_cast<std::int32_t>(rows.size());
    density_of[m.label] = static_cast<float>(m.voxel_density());
    rows.push_back({m.name.empty() ? "label " + std::to_string(m.label) : m.name, m.elastic,
                    m.yield_stress_pa.value_or(fallback.yield_stress_pa)});
  }
  const Vec3i& dims = map.dims();
  auto label_at = [&](int i, int j, int k) { return map.at(Vec3i(i, j, k)); };
  openvdb::FloatGrid::Ptr grid = io::build_grid(dims, [&](int i, int j, int k) {
    const auto it = density_of.find(label_at(i, j, k));
    return it == density_of.end() ? 0.0f : it->second;
  });
  auto slots = openvdb::Int32Grid::create(0);
  auto accessor = slots->getAccessor();
  for (int k = 0; k < dims.z(); ++k) {
    for (int j = 0; j < dims.y(); ++j) {
      for (int i = 0; i < dims.x(); ++i) {
        const auto it = slot_of.find(label_at(i, j, k));
        if (it != slot_of.end()) accessor.setValue(openvdb::Coord(i, j, k), it->second);
      }
    }
  }
  return TissueVolume{DensityField(grid, map.spacing_mm(), map.origin_mm(), dims),
                      TissueMap(std::move(rows), slots)};
}

}  // namespace hapvox::engine::labels
