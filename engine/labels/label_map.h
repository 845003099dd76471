#pragma once
// Labels (Nakao et al. 2010, §3.2): one integer per voxel over a volume's index grid, with the
// volume's geometry (index (0,0,0) is the centre of the first voxel; world = origin +
// ijk * spacing, as in engine/density_field.h). Label 0 is the background. The proxy mesh
// refines at the label boundaries |∇L| ≠ 0 and takes each tet's material from its label
// (engine/labels/materials.h).
//
// Four ways to make a map: a label volume (read_label_volume), intensity ranges
// (labels_from_intensity_ranges), region growing from seed points (grow_regions), and
// picking a voxel on the rendered image (pick_voxel) to seed the growing with.
//
// "Intensity" is a dense scalar volume, engine::RawVolume: a NRRD's raw samples (read_nrrd,
// before any density mapping), or a density field's densities (dense_intensity).

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "engine/density_field.h"
#include "engine/volume_io.h"

namespace hapvox::engine::labels {

using Label = std::int32_t;

/// The largest label a file may hold: every label up to it is exact in a float sample.
constexpr Label kMaxLabel = 1 << 24;

class LabelMap {
 public:
  /// All background (0) over `dims` voxels with this geometry.
  LabelMap(const Vec3i& dims, const Vec3d& spacing_mm, const Vec3d& origin_mm);
  /// All background, with the geometry of `volume`.
  static LabelMap like(const RawVolume& volume);
  static LabelMap like(const DensityField& field);

  const Vec3i& dims() const { return dims_; }
  const Vec3d& spacing_mm() const { return spacing_mm_; }
  const Vec3d& origin_mm() const { return origin_mm_; }
  std::int64_t voxel_count() const { return static_cast<std::int64_t>(labels_.size()); }

  Vec3d index_to_world(const Vec3d& ijk) const {
    return origin_mm_ + ijk.cwiseProduct(spacing_mm_);
  }
  Vec3d world_to_index(const Vec3d& p_mm) const {
    return (p_mm - origin_mm_).cwiseQuotient(spacing_mm_);
  }
  /// The voxel whose cell (centre ± half a voxel) holds `p_mm`, or none outside the volume.
  std::optional<Vec3i> voxel_at_world(const Vec3d& p_mm) const;

  bool contains(const Vec3i& ijk) const {
    return (ijk.array() >= 0).all() && (ijk.array() < dims_.array()).all();
  }
  /// x fastest, as in RawVolume.
  std::int64_t linear_index(const Vec3i& ijk) const {
    return ijk.x() + static_cast<std::int64_t>(dims_.x()) *
                         (ijk.y() + static_cast<std::int64_t>(dims_.y()) * ijk.z());
  }
  Label at(const Vec3i& ijk) const;
  void set(const Vec3i& ijk, Label label);
  /// The label at a world point (its voxel's), 0 outside the volume.
  Label at_world(const Vec3d& p_mm) const;

  const std::vector<Label>& data() const { return labels_; }
  std::vector<Label>& mutable_data() { return labels_; }

  /// Voxels per label, for every label present (0 included when present).
  std::map<Label, std::int64_t> voxel_counts() const;
  /// |∇L| ≠ 0: a 6-neighbour inside the volume holds another label. The volume's outer faces
  /// are not boundaries.
  bool is_boundary(const Vec3i& ijk) const;
  /// The boundary voxels of label `label` (in x-fastest order).
  std::vector<Vec3i> boundary_voxels(Label label) const;

 private:
  Vec3i dims_;
  Vec3d spacing_mm_;
  Vec3d origin_mm_;
  std::vector<Label> labels_;
};

/// A density field sampled densely over its index box [0, dims), and the unmapped scalar
/// samples of any volume the engine reads (engine/io/formats.h).
using io::dense_intensity;
using io::read_scalar_volume;

/// A label volume (any volume read_scalar_volume reads) as labels over `intensity`'s grid.
/// Throws InputError(label_spec, ...) when a value is not an integer in [0, kMaxLabel], or
/// when its size, spacing or origin differ from the intensity volume's (named
/// `intensity_name` in the message).
LabelMap read_label_volume(const std::string& label_spec, const RawVolume& intensity,
                           const std::string& intensity_name);
/// The same from values already read (`label_volume` named `label_source` in errors).
LabelMap label_volume_to_map(const RawVolume& label_volume, const std::string& label_source,
                             const RawVolume& intensity, const std::string& intensity_name);

/// The map as a volume of float labels, for write_nrrd / write_vdb (label 0 stays inactive).
DensityField label_field(const LabelMap& map);

/// The map's labels as samples over its grid (axis-aligned), for io::write_label_volume:
/// a label file that reads back as this map.
RawVolume label_samples(const LabelMap& map);

/// Voxels with low <= intensity <= high get `label`; the first matching range wins, voxels
/// no range matches stay 0.
struct IntensityRange {
  Label label = 0;
  double low = 0.0;
  double high = 0.0;
};
LabelMap labels_from_intensity_ranges(const RawVolume& intensity,
                                      const std::vector<IntensityRange>& ranges);

/// A seed point for region growing: world millimetres and the label its region gets (> 0).
struct Seed {
  Vec3d point_mm = Vec3d::Zero();
  Label label = 1;
};

/// Grows one region into `map`: a 6-connected flood fill from the seed's voxel through
/// voxels with |I - I_seed| <= tolerance that are still background (0) in `map`. Returns the
/// number of voxels labelled (0 when the seed's voxel is already labelled). Throws
/// InputError(source, ...) for a seed outside the volume.
std::int64_t grow_region(LabelMap& map, const RawVolume& intensity, const Seed& seed,
                         double tolerance, const std::string& source);
/// A fresh map with one grown region per seed, in order (earlier seeds keep their voxels).
LabelMap grow_regions(const RawVolume& intensity, const std::vector<Seed>& seeds, double tolerance,
                      const std::string& source);

/// Picking (§3.2): the first voxel along a ray where the front-to-back accumulated opacity
/// reaches `threshold`. `opacity(I)` is the opacity of one voxel of path (the smallest
/// spacing) through intensity I, as a transfer function's is; the ray walks every voxel it
/// crosses (Amanatides–Woo) with opacity 1 - (1 - a)^(length / voxel).
struct Pick {
  Vec3i voxel = Vec3i::Zero();
  double depth_mm = 0.0;  // distance from the ray origin to where the ray enters the voxel
  double accumulated_opacity = 0.0;
};
std::optional<Pick> pick_voxel(const RawVolume& intensity, const Vec3d& origin_mm,
                               const Vec3d& direction, const std::function<float(float)>& opacity,
                               double threshold = 0.5);

}  // namespace hapvox::engine::labels
