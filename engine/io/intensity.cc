#include "engine/io/intensity.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

#include "engine/check.h"
#include "engine/errors.h"
#include "engine/io/grid_build.h"

namespace hapvox::engine::io {

double otsu_threshold(const RawVolume& raw) {
  constexpr int kBins = 256;
  const double lo = raw.min_intensity;
  const double hi = raw.max_intensity;
  if (raw.intensity.empty() || !(hi > lo)) return lo;  // constant volume: no split exists
  const double width = (hi - lo) / kBins;
  std::array<double, kBins> hist{};
  for (float v : raw.intensity) {
    const int bin = std::clamp(static_cast<int>((v - lo) / width), 0, kBins - 1);
    hist[static_cast<std::size_t>(bin)] += 1.0;
  }
  const double total = static_cast<double>(raw.intensity.size());
  double sum_all = 0.0;
  for (int i = 0; i < kBins; ++i) sum_all += i * hist[static_cast<std::size_t>(i)];
  double w0 = 0.0;
  double sum0 = 0.0;
  double best = -1.0;
  int best_bin = 0;
  for (int k = 0; k < kBins - 1; ++k) {
    w0 += hist[static_cast<std::size_t>(k)];
    sum0 += k * hist[static_cast<std::size_t>(k)];
    const double w1 = total - w0;
    if (w0 == 0.0 || w1 == 0.0) continue;
    const double mean0 = sum0 / w0;
    const double mean1 = (sum_all - sum0) / w1;
    const double between = w0 * w1 * (mean0 - mean1) * (mean0 - mean1);
    if (between > best) {
      best = between;
      best_bin = k;
    }
  }
  // Threshold at the upper edge of the last background bin: v >= t is material.
  return lo + (best_bin + 1) * width;
}

IntensityMapping threshold_mapping(double threshold) {
  if (!std::isfinite(threshold)) throw InputError("--threshold", "must be finite");
  IntensityMapping mapping;
  mapping.kind = IntensityMapping::Kind::kThreshold;
  mapping.low = threshold;
  return mapping;
}

IntensityMapping window_mapping(double low, double high) {
  if (!std::isfinite(low) || !std::isfinite(high)) throw InputError("--window", "must be finite");
  if (high <= low) throw InputError("--window", "HI must exceed LO");
  IntensityMapping mapping;
  mapping.kind = IntensityMapping::Kind::kWindow;
  mapping.low = low;
  mapping.high = high;
  return mapping;
}

DensityField map_to_density(const RawVolume& raw, const IntensityMapping& mapping,
                            const std::string& source_name) {
  const Vec3i dims = raw.dims;
  HAPVOX_CHECK_EQ(raw.intensity.size(), static_cast<std::size_t>(dims.x()) *
                                            static_cast<std::size_t>(dims.y()) *
                                            static_cast<std::size_t>(dims.z()));
  if (!std::isfinite(mapping.low) ||
      (mapping.kind == IntensityMapping::Kind::kWindow && !std::isfinite(mapping.high))) {
    throw InputError(source_name, "intensity mapping bounds must be finite");
  }
  const std::size_t nx = static_cast<std::size_t>(dims.x());
  const std::size_t nxy = nx * static_cast<std::size_t>(dims.y());
  auto at = [&](int x, int y, int z) {
    return raw.intensity[static_cast<std::size_t>(z) * nxy + static_cast<std::size_t>(y) * nx +
                         static_cast<std::size_t>(x)];
  };
  openvdb::FloatGrid::Ptr grid;
  if (mapping.kind == IntensityMapping::Kind::kWindow) {
    if (!(mapping.high > mapping.low)) {
      throw InputError(source_name, "window high must exceed low");
    }
    const double low = mapping.low;
    const double inv = 1.0 / (mapping.high - mapping.low);
    grid = build_grid(dims, [&](int x, int y, int z) {
      return static_cast<float>(std::clamp((at(x, y, z) - low) * inv, 0.0, 1.0));
    });
  } else {
    const double t =
        mapping.kind == IntensityMapping::Kind::kAuto ? otsu_threshold(raw) : mapping.low;
    grid = build_grid(dims, [&](int x, int y, int z) { return at(x, y, z) >= t ? 1.0f : 0.0f; });
  }
  return DensityField(grid, raw.spacing_mm, raw.origin_mm, dims, raw.direction);
}

DensityField load_samples(const RawVolume& raw, const IntensityMapping& mapping,
                          const std::string& source_name) {
  if (!raw.holds_density) return map_to_density(raw, mapping, source_name);
  // Sculpted clay exceeds 1 where compressed; far beyond is a corrupt or foreign file.
  constexpr float kMaxDensity = 1000.0f;
  if (raw.min_intensity < 0.0 || raw.max_intensity > kMaxDensity) {
    throw InputError(source_name, "density file holds densities outside [0, 1000] (" +
                                      std::to_string(raw.min_intensity) + " .. " +
                                      std::to_string(raw.max_intensity) + ")");
  }
  const std::size_t nx = static_cast<std::size_t>(raw.dims.x());
  const std::size_t nxy = nx * static_cast<std::size_t>(raw.dims.y());
  auto grid = build_grid(raw.dims, [&](int x, int y, int z) {
    return raw.intensity[static_cast<std::size_t>(z) * nxy + static_cast<std::size_t>(y) * nx +
                         static_cast<std::size_t>(x)];
  });
  return DensityField(grid, raw.spacing_mm, raw.origin_mm, raw.dims, raw.direction);
}

}  // namespace hapvox::engine::io
