#pragma once
// A volume: the density field a tool touches, from a scan file, a folder of DICOM slices,
// a generator, or your own array. Densities lie in [0, 1] (0: empty, 1: full material);
// scanner intensities are mapped to them on loading (a threshold, a window, or Otsu's
// threshold when neither is given), as `hapvox replay --volume` does.

#include <array>
#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace hapvox {

/// How intensities become densities (`--threshold`, `--window`); neither: Otsu's threshold.
/// Files that hold hapvox densities (written by hapvox) are read as they are.
struct IntensityOptions {
  std::optional<double> threshold;              // density 1 where intensity >= threshold
  std::optional<std::array<double, 2>> window;  // clamp((v - lo) / (hi - lo), 0, 1)
};

class Volume {
 public:
  /// Reads `spec` as `--volume` does: a file (.nrrd, .nhdr, .nii, .mha, .mhd, .vdb, .hdr,
  /// raw with options), a folder of DICOM slices, or a generator ("block", "sphere", ...:
  /// docs/formats.md). Throws InputError naming the file and the problem.
  static Volume load(const std::string& spec, const IntensityOptions& intensity = {});

  /// A volume from densities in [0, 1], x fastest: density[i + dims[0] * (j + dims[1] * k)]
  /// is voxel (i, j, k), centred at origin_mm + (i, j, k) * spacing_mm. Throws
  /// InputError("array", ...) on a size that does not match, a density outside [0, 1] or
  /// non-finite, or a non-positive spacing.
  static Volume from_densities(const std::vector<float>& density, std::array<int, 3> dims,
                               std::array<double, 3> spacing_mm = {1.0, 1.0, 1.0},
                               std::array<double, 3> origin_mm = {0.0, 0.0, 0.0});

  /// Voxels per axis (the index box [0, dims)).
  std::array<int, 3> dims() const;
  std::array<double, 3> spacing_mm() const;
  /// World position of voxel (0, 0, 0)'s centre.
  std::array<double, 3> origin_mm() const;
  /// The world box the voxels cover (voxel faces, not centres).
  std::array<double, 3> world_min_mm() const;
  std::array<double, 3> world_max_mm() const;
  /// The densities over the index box, x fastest (the layout of from_densities).
  std::vector<float> densities() const;
  /// Writes the densities as .nrrd or .vdb (by extension), marked as densities so they read
  /// back unchanged. Never over the file the volume was read from.
  void save(const std::string& path) const;
  /// What it was loaded from ("array" for from_densities).
  const std::string& source() const;

  struct Impl;
  /// Internal: hapvox's own code reaches the field through this.
  const Impl& impl() const { return *impl_; }

 private:
  explicit Volume(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}
  std::shared_ptr<const Impl> impl_;  // immutable: copies share it
};

}  // namespace hapvox
