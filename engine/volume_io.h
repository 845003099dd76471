#pragma once
// Volume input and output: NRRD (.nrrd attached / .nhdr detached header; raw or gzip;
// any integer or float sample type; spacings or space directions), OpenVDB (.vdb), the
// intensity -> density mapping, and the synthetic generators.
//
// Every user-facing failure throws hapvox::InputError naming the file and the problem.

#include <string>
#include <vector>

#include "engine/density_field.h"

namespace hapvox::engine {

/// A scalar volume as read from disk, before mapping to density. x varies fastest.
struct RawVolume {
  std::vector<float> intensity;  // dims.prod() samples, converted to float
  Vec3i dims = Vec3i::Zero();
  Vec3d spacing_mm = Vec3d::Ones();
  Vec3d origin_mm = Vec3d::Zero();
  std::string sample_type;  // NRRD type name as normalised, e.g. "uint8", "int16", "float"
  double min_intensity = 0.0;
  double max_intensity = 0.0;
};

/// Reads a NRRD volume (3-D, scalar). Throws InputError("PATH", "...") on any problem:
/// missing file, bad magic, unsupported/missing fields, wrong dimension, truncated or
/// corrupt payload, NaN or infinite samples, non-positive spacing.
RawVolume read_nrrd(const std::string& path);

/// The detached data file a NRRD header names ("data file: F", F resolved against the
/// header's folder as read_nrrd does), or "" when its data is attached (or multi-file).
/// Throws InputError on a file that is not a NRRD.
std::string nrrd_data_file(const std::string& path);

/// Writes a density field as a NRRD (float, gzip, attached header) with spacings and
/// origin, covering the index box [0, dims). Written to PATH.partial then renamed.
void write_nrrd(const DensityField& field, const std::string& path);

/// How raw intensities become densities in [0, 1].
struct IntensityMapping {
  enum class Kind { kAuto, kThreshold, kWindow };
  Kind kind = Kind::kAuto;
  double low = 0.0;   // threshold value (kThreshold) or window low (kWindow)
  double high = 0.0;  // window high (kWindow)
};

/// Maps intensities to densities: kThreshold gives 1 where v >= low, else 0; kWindow gives
/// clamp((v - low) / (high - low), 0, 1); kAuto is a threshold at Otsu's value.
/// Voxels of density 0 stay inactive background.
DensityField map_to_density(const RawVolume& raw, const IntensityMapping& mapping,
                            const std::string& source_name);

/// Otsu's threshold of the intensities (256-bin histogram between min and max).
double otsu_threshold(const RawVolume& raw);

/// Reads the float grid named "density" (or, failing that, the first float grid) of a
/// .vdb file. Voxel size and origin come from the grid's transform; dims from the
/// "hapvox_dims" metadata if present, else the active bounding box.
DensityField read_vdb(const std::string& path);

/// Writes the field as grid "density" with its transform and dims metadata.
void write_vdb(const DensityField& field, const std::string& path);

/// Synthetic generators, spec "NAME[:key=value,...]":
///   block[:dims=N,voxel_mm=V,fill=F]   clay block: the lower F (default 0.5) of an N^3 box
///   sphere[:dims=N,voxel_mm=V,radius_mm=R]  solid sphere centred in an N^3 box
///   four-spheres[:dims=N,voxel_mm=V]   Nakao's phantom: four spheres of densities
///                                      0.4/0.6/0.8/1.0 in an N^3 box (default N=128)
/// Defaults: dims=128, voxel_mm=1. Throws InputError("generator SPEC", ...) on bad specs.
DensityField generate_volume(const std::string& spec);

/// True when `spec` names a generator rather than a file.
bool is_generator_spec(const std::string& spec);

/// Loads a file (.nrrd/.nhdr through `mapping`, .vdb as stored) or runs a generator.
DensityField load_volume(const std::string& spec, const IntensityMapping& mapping);

}  // namespace hapvox::engine
