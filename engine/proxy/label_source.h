#pragma once
// Where the proxy model's labels come from (docs/materials.md): a label volume when one is
// given (--labels), else region growing from seed points (--seed), else the materials file's
// intensity ranges. Exactly one of them makes the label map.

#include <optional>
#include <string>
#include <vector>

#include "engine/labels/label_map.h"
#include "engine/labels/materials.h"
#include "engine/volume_io.h"

namespace hapvox::engine::proxy {

struct LabelSourceOptions {
  /// The intensity volume as errors name it (a file or generator spec).
  std::string intensity_name = "volume";
  /// A label volume's spec (read_label_volume); "" for none.
  std::string label_volume;
  /// Seeds for region growing, in order (earlier seeds keep their voxels).
  std::vector<labels::Seed> seeds;
  /// |I - I_seed| a grown region accepts; none: 10 % of the intensity range.
  std::optional<double> seed_tolerance;
  /// Names the seeds in errors (a seed outside the volume, a bad tolerance).
  std::string seed_source = "--seed";
};

/// The label map over `intensity`'s grid: from the label volume, else the seeds, else the
/// materials' intensity ranges. Throws InputError(seed_source, ...) when both a label volume
/// and seeds are given, and InputError(materials.source, ...) when none of the three is.
labels::LabelMap proxy_labels(const RawVolume& intensity, const labels::Materials& materials,
                              const LabelSourceOptions& options);

}  // namespace hapvox::engine::proxy
