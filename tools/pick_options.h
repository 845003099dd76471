#pragma once
// Picking labels on the rendered image (Nakao §3.2) for `hapvox mesh` and `replay --model
// fem`: --pick PX,PY[:LABEL] names a pixel of the image `hapvox render VOLUME` draws with the
// same --pick-size, --pick-view and --pick-transfer (its defaults are render's). The ray
// through that pixel's centre stops at the first voxel where the transfer function's
// accumulated opacity reaches --pick-threshold (engine/labels/label_map.h, pick_voxel); that
// voxel seeds a grown region, like --seed.

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "engine/labels/label_map.h"
#include "engine/volume_io.h"

namespace hapvox::cli {

struct PickCliOptions {
  std::vector<std::string> picks;  // "PX,PY[:LABEL]": pixel column and row (0 at the top)
  std::string size = "512";        // the image: N or WxH, as render's --size
  std::string view = "30,25";      // azimuth, elevation (degrees), as render's defaults
  std::string transfer = "auto";   // as render's --transfer
  double threshold = 0.5;          // accumulated opacity that stops the ray, in (0, 1)
};

/// Registers --pick, --pick-size, --pick-view, --pick-transfer, --pick-threshold.
void add_pick_options(CLI::App& app, PickCliOptions& options);

/// The picks' parsed pixels and labels, checked before any volume is read (InputError
/// naming the flag). A pick without a label gets `first_label`, `first_label` + 1, ...
struct PixelPick {
  int x = 0, y = 0;
  engine::labels::Label label = 1;
};
std::vector<PixelPick> parse_picks(const PickCliOptions& options,
                                   engine::labels::Label first_label);

/// One seed per pick: the centre of the voxel the pixel's ray stops at. `volume_spec` is the
/// volume as given (a generator's intensities are its densities; a file's are mapped to
/// densities as render maps them by default: a threshold at Otsu's value). Throws
/// InputError("--pick", ...) for a pixel whose ray sees nothing.
std::vector<engine::labels::Seed> seeds_from_picks(const engine::RawVolume& intensity,
                                                   const std::string& volume_spec,
                                                   const PickCliOptions& options,
                                                   const std::vector<PixelPick>& picks);

}  // namespace hapvox::cli
