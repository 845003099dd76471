// hapvox::Volume: a density field behind the public API (include/hapvox/volume.h).

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "api/volume_impl.h"
#include "engine/errors.h"
#include "engine/io/intensity.h"
#include "engine/volume_io.h"
#include "hapvox/volume.h"

namespace hapvox {

namespace {

// --threshold / --window, with the command line's words (tools/cli.cc: MappingFlags).
engine::IntensityMapping mapping_of(const IntensityOptions& options) {
  if (options.threshold && options.window) {
    throw InputError("--window", "cannot be combined with --threshold");
  }
  if (options.threshold) return engine::io::threshold_mapping(*options.threshold);
  if (options.window) return engine::io::window_mapping((*options.window)[0], (*options.window)[1]);
  return {};
}

Eigen::Vector3d vec(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }
std::array<double, 3> arr(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace

Volume Volume::load(const std::string& spec, const IntensityOptions& intensity) {
  auto impl = std::make_shared<Impl>(Impl{engine::load_volume(spec, mapping_of(intensity)), spec});
  return Volume(std::move(impl));
}

Volume Volume::from_densities(const std::vector<float>& density, std::array<int, 3> dims,
                              std::array<double, 3> spacing_mm, std::array<double, 3> origin_mm) {
  for (int d : dims) {
    if (d <= 0) throw InputError("array", "dims must be positive");
  }
  const std::size_t count = static_cast<std::size_t>(dims[0]) * static_cast<std::size_t>(dims[1]) *
                            static_cast<std::size_t>(dims[2]);
  if (density.size() != count) {
    throw InputError("array", std::to_string(density.size()) + " densities for dims " +
                                  std::to_string(dims[0]) + "x" + std::to_string(dims[1]) + "x" +
                                  std::to_string(dims[2]) + " (" + std::to_string(count) +
                                  " voxels)");
  }
  for (std::size_t i = 0; i < 3; ++i) {
    if (!(std::isfinite(spacing_mm[i]) && spacing_mm[i] > 0.0)) {
      throw InputError("array", "spacing_mm must be positive");
    }
    if (!std::isfinite(origin_mm[i])) throw InputError("array", "origin_mm must be finite");
  }
  for (std::size_t i = 0; i < density.size(); ++i) {
    if (!(density[i] >= 0.0f && density[i] <= 1.0f)) {
      throw InputError("array", "density " + std::to_string(density[i]) + " at index " +
                                    std::to_string(i) + " is outside [0, 1]");
    }
  }
  engine::RawVolume raw;
  raw.intensity = density;
  raw.dims = engine::Vec3i(dims[0], dims[1], dims[2]);
  raw.spacing_mm = vec(spacing_mm);
  raw.origin_mm = vec(origin_mm);
  raw.holds_density = true;
  raw.sample_type = "float";
  raw.min_intensity = density.empty() ? 0.0 : *std::min_element(density.begin(), density.end());
  raw.max_intensity = density.empty() ? 0.0 : *std::max_element(density.begin(), density.end());
  auto impl = std::make_shared<Impl>(
      Impl{engine::io::load_samples(raw, engine::IntensityMapping{}, "array"), "array"});
  return Volume(std::move(impl));
}

std::array<int, 3> Volume::dims() const {
  const engine::Vec3i& d = impl_->field.dims();
  return {d.x(), d.y(), d.z()};
}
std::array<double, 3> Volume::spacing_mm() const { return arr(impl_->field.voxel_size_mm()); }
std::array<double, 3> Volume::origin_mm() const { return arr(impl_->field.origin_mm()); }
std::array<double, 3> Volume::world_min_mm() const { return arr(impl_->field.world_min_mm()); }
std::array<double, 3> Volume::world_max_mm() const { return arr(impl_->field.world_max_mm()); }
const std::string& Volume::source() const { return impl_->source; }

std::vector<float> Volume::densities() const {
  return engine::dense_intensity(impl_->field).intensity;
}

void Volume::save(const std::string& path) const {
  std::error_code error;
  if (std::filesystem::equivalent(path, impl_->source, error)) {
    throw InputError(path, "would overwrite the volume it was read from");
  }
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".nrrd") {
    engine::write_nrrd(impl_->field, path);
  } else if (ext == ".vdb") {
    engine::write_vdb(impl_->field, path);
  } else {
    throw InputError(path, "cannot write '" + ext + "' volumes (.nrrd or .vdb)");
  }
}

}  // namespace hapvox
