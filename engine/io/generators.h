#pragma once
// Synthetic volumes, named by a spec "NAME[:key=value,...]" where a file name would go.

#include <string>
#include <vector>

#include "engine/density_field.h"

namespace hapvox::engine::io {

/// A generator's options, parsed from its spec.
struct GeneratorOptions {
  int dims = 128;  // an N^3 box
  double voxel_mm = 1.0;
  double fill = 0.5;         // block
  double radius_mm = -1.0;   // sphere; < 0: 0.35 of the box
  bool binary_edge = false;  // sphere: edge voxels 1 or 0 instead of the share inside
};

/// One generator: its name, what it makes, the options it takes besides the common
/// dims=N and voxel_mm=V, and the function making it.
struct VolumeGenerator {
  const char* name;
  const char* what;
  std::vector<std::string> options;
  DensityField (*make)(const GeneratorOptions& options);
};

/// Every generator, in the order help texts list them:
///   block[:dims=N,voxel_mm=V,fill=F]   clay block: the lower F (default 0.5) of an N^3 box
///   sphere[:dims=N,voxel_mm=V,radius_mm=R,edge=partial|binary]  solid sphere centred in an
///                                      N^3 box; its edge voxels hold the share of them
///                                      inside (partial, the default) or 1 / 0 (binary)
///   four-spheres[:dims=N,voxel_mm=V]   Nakao's phantom: four spheres of densities
///                                      0.4/0.6/0.8/1.0 in an N^3 box (default N=128)
/// Defaults: dims=128, voxel_mm=1.
const std::vector<VolumeGenerator>& volume_generators();

/// Runs a generator spec. Throws InputError("generator SPEC", ...) on bad specs.
DensityField generate_volume(const std::string& spec);

/// True when `spec` names a generator rather than an existing file.
bool is_generator_spec(const std::string& spec);

}  // namespace hapvox::engine::io
