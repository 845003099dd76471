#pragma once
// Materials by tissue for the voxel model, from a label map and a materials file
// (docs/materials.md, docs/physics.md "Materials by tissue"): each labelled voxel gets its
// label's material's density (Material::voxel_density) and its material's row in a
// TissueMap, so the tool feels bone hard and fat soft.

#include "engine/density_field.h"
#include "engine/labels/label_map.h"
#include "engine/labels/materials.h"
#include "engine/tissue_map.h"

namespace hapvox::engine::labels {

/// A density field and the materials of its voxels, made together from labels.
struct TissueVolume {
  DensityField field;
  TissueMap tissue;
};

/// The voxel model's volume from `map` (axis-aligned, its spacing and origin) and
/// `materials`: row 0 of the table is `fallback` (the command's material, for voxels
/// without one: background without a material, and sculpted material flowing into it),
/// then one row per material in file order, its yield stress the file's or the fallback's.
/// Label 0 without a material stays empty; every other label present needs a material,
/// else InputError(materials.source, "label 3 has no material (120 voxels)").
TissueVolume tissue_volume(const LabelMap& map, const Materials& materials,
                           const TissueMaterial& fallback);

}  // namespace hapvox::engine::labels
