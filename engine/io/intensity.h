#pragma once
// How a scanner's intensities become densities in [0, 1].

#include <string>

#include "engine/density_field.h"
#include "engine/io/raw_volume.h"

namespace hapvox::engine::io {

/// How raw intensities become densities in [0, 1].
struct IntensityMapping {
  enum class Kind { kAuto, kThreshold, kWindow };
  Kind kind = Kind::kAuto;
  double low = 0.0;   // threshold value (kThreshold) or window low (kWindow)
  double high = 0.0;  // window high (kWindow)
};

/// A threshold mapping at `threshold` (the flag --threshold). Throws
/// InputError("--threshold", ...) unless it is finite.
IntensityMapping threshold_mapping(double threshold);

/// A window mapping from `low` to `high` (the flag --window LO,HI). Throws
/// InputError("--window", ...) unless both are finite and high exceeds low.
IntensityMapping window_mapping(double low, double high);

/// Maps intensities to densities: kThreshold gives 1 where v >= low, else 0; kWindow gives
/// clamp((v - low) / (high - low), 0, 1); kAuto is a threshold at Otsu's value.
/// Voxels of density 0 stay inactive background.
DensityField map_to_density(const RawVolume& raw, const IntensityMapping& mapping,
                            const std::string& source_name);

/// A volume as a density field: a density file hapvox wrote (raw.holds_density) as stored,
/// each sample its voxel's density, so sculpt, save, reload keeps the mass bit for bit;
/// scanner samples through `mapping`. Throws InputError(source_name, ...) on a density file
/// with densities outside [0, 1000].
DensityField load_samples(const RawVolume& raw, const IntensityMapping& mapping,
                          const std::string& source_name);

/// Otsu's threshold of the intensities (256-bin histogram between min and max).
double otsu_threshold(const RawVolume& raw);

}  // namespace hapvox::engine::io
