#include "engine/proxy/label_source.h"

#include "engine/errors.h"

namespace hapvox::engine::proxy {

labels::LabelMap proxy_labels(const RawVolume& intensity, const labels::Materials& materials,
                              const LabelSourceOptions& options) {
  if (!options.label_volume.empty() && !options.seeds.empty()) {
    throw InputError(options.seed_source,
                     "seeds cannot be combined with a label volume (" + options.label_volume + ")");
  }
  if (!options.label_volume.empty()) {
    return labels::read_label_volume(options.label_volume, intensity, options.intensity_name);
  }
  if (!options.seeds.empty()) {
    // A relative default: intensities run from 0-1 densities to CT numbers in the thousands.
    const double tolerance =
        options.seed_tolerance.value_or(0.1 * (intensity.max_intensity - intensity.min_intensity));
    return labels::grow_regions(intensity, options.seeds, tolerance, options.seed_source);
  }
  const std::vector<labels::IntensityRange> ranges = materials.intensity_ranges();
  if (ranges.empty()) {
    throw InputError(materials.source,
                     "no labels: the file gives no intensity ranges, and no label volume "
                     "(--labels) or seeds (--seed) were given");
  }
  return labels::labels_from_intensity_ranges(intensity, ranges);
}

}  // namespace hapvox::engine::proxy
