#pragma once
// The four-spheres phantom with data/four_spheres.toml: what the proxy tests build from.

#include "../labels/four_spheres.h"
#include "engine/labels/label_map.h"
#include "engine/labels/materials.h"
#include "test_data.h"

namespace hapvox::testing {

struct PhantomInputs {
  explicit PhantomInputs(int n) : spheres{n, 1.0} {}
  FourSpheres spheres;
  engine::RawVolume intensity = engine::labels::read_scalar_volume(spheres.spec());
  engine::labels::Materials materials =
      engine::labels::read_materials(source_path("data/four_spheres.toml"));
};

}  // namespace hapvox::testing
