#pragma once
// The materials file (TOML, docs/materials.md): each label's elastic material (E, ν), whether
// it is fixed or deformable, optionally a name and an intensity range that makes the label
// (labels_from_intensity_ranges), and fixed regions (a box in world millimetres, or one side
// of a label) whose material is held in place, as the white sphere's left side in Nakao's
// Fig. 5.
//
// Every problem throws InputError("FILE:LINE", PROBLEM) with the line of the offending key
// or table (toml++'s source positions), or InputError("FILE", PROBLEM) for the file as a
// whole, so the command line prints one line "hapvox: error: FILE:LINE: PROBLEM".

#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "engine/labels/label_map.h"
#include "engine/material.h"

namespace hapvox::engine::labels {

struct Material {
  Label label = 0;
  std::string name;  // "" when the file gives none
  ElasticMaterial elastic;
  bool fixed = false;  // fixed: its voxels never move (Dirichlet); else deformable
  std::optional<IntensityRange> intensity;
  /// The voxel model's density for the label's voxels, in [0, 1] (docs/materials.md).
  std::optional<double> density;
  /// The voxel model's yield stress sigma_f (Pa) for the label; absent: the command's.
  std::optional<double> yield_stress_pa;
  int line = 0;  // of its [[material]] header

  /// The density the voxel model gives the label's voxels: `density`, else 1 for a label
  /// and 0 for the background (label 0), which stays empty unless the file says otherwise.
  double voxel_density() const { return density ? *density : (label == 0 ? 0.0 : 1.0); }
};

/// A region of material held in place: either a box in world millimetres, or the outer
/// `fraction` of a label's extent on one side (its voxels' bounding box, faces included).
/// With a label, only that label's material in the region is fixed.
struct FixedRegion {
  enum class Side { kNone, kMinusX, kPlusX, kMinusY, kPlusY, kMinusZ, kPlusZ };
  std::optional<Label> label;
  Side side = Side::kNone;
  double fraction = 0.5;
  Vec3d min_mm = Vec3d::Zero();  // with Side::kNone
  Vec3d max_mm = Vec3d::Zero();
  int line = 0;  // of its [[fixed_region]] header
};

/// A fixed region made concrete on a label map: a world box and an optional label.
struct FixedBox {
  Vec3d min_mm = Vec3d::Zero();
  Vec3d max_mm = Vec3d::Zero();
  std::optional<Label> label;
  /// True when `p_mm` lies in the box (faces included) and, with a label, `label_at_p` is it.
  bool contains(const Vec3d& p_mm, Label label_at_p) const;
};

struct Materials {
  std::string source;               // the file, as errors name it
  std::vector<Material> materials;  // in file order, labels unique
  std::vector<FixedRegion> fixed_regions;

  /// The material of `label`, or nullptr.
  const Material* find(Label label) const;
  /// The intensity ranges the file gives, in file order (for labels_from_intensity_ranges).
  std::vector<IntensityRange> intensity_ranges() const;
  /// The labels whose material is fixed.
  std::set<Label> fixed_labels() const;
};

/// Parses a materials file's text; `source` names it in errors.
Materials parse_materials(std::string_view text, const std::string& source);
/// Reads and parses a materials file.
Materials read_materials(const std::string& path);

/// Every label present in `map` has a material, else InputError(materials.source,
/// "label 3 has no material (120 voxels)") (several: "labels 3 (120 voxels), 5 (7 voxels)
/// have no material"). Without `background_needs_material`, label 0 may go without one.
void check_labels_have_materials(const LabelMap& map, const Materials& materials,
                                 bool background_needs_material = true);

/// The fixed regions as world boxes on `map`. Throws InputError("FILE:LINE", ...) when a
/// region's side names a label the map does not hold.
std::vector<FixedBox> resolve_fixed_regions(const Materials& materials, const LabelMap& map);

/// Per voxel (x fastest): 1 where the voxel's material is fixed or its centre lies in a fixed
/// region, else 0. Checks the labels have materials first.
std::vector<std::uint8_t> fixed_voxels(const LabelMap& map, const Materials& materials);

}  // namespace hapvox::engine::labels
