#pragma once
// What a hapvox::Volume holds (include/hapvox/volume.h declares it opaque).

#include <string>

#include "engine/density_field.h"
#include "hapvox/volume.h"

namespace hapvox {

struct Volume::Impl {
  engine::DensityField field;
  std::string source;
};

}  // namespace hapvox
