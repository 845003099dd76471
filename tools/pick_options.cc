#include "tools/pick_options.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "engine/errors.h"
#include "render/camera.h"
#include "render/transfer_function.h"
#include "tools/cli.h"
#include "tools/render_output.h"

namespace hapvox::cli {
namespace {

int parse_int(const std::string& text, const std::string& what, const std::string& whole) {
  int value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size()) {
    throw InputError("--pick",
                     "expected PX,PY[:LABEL] with integer " + what + ", got '" + whole + "'");
  }
  return value;
}

std::vector<double> parse_view(const std::string& text) {
  const std::vector<double> view = parse_number_list(text, "--pick-view");
  if (view.size() != 2) {
    throw InputError("--pick-view", "expected AZIMUTH,ELEVATION in degrees, got '" + text + "'");
  }
  return view;
}

}  // namespace

void add_pick_options(CLI::App& app, PickCliOptions& options) {
  app.add_option("--pick", options.picks,
                 "PX,PY[:LABEL]: grow LABEL's region from the first voxel the pixel (column, "
                 "row from the top) of `hapvox render`'s image shows (repeatable)")
      ->allow_extra_args(false);
  app.add_option("--pick-size", options.size, "--pick's image size, N or WxH (render's --size)")
      ->capture_default_str();
  app.add_option("--pick-view", options.view,
                 "--pick's camera azimuth,elevation in degrees (render's --azimuth-deg, "
                 "--elevation-deg)")
      ->capture_default_str();
  app.add_option("--pick-transfer", options.transfer,
                 "--pick's transfer function (render's --transfer)")
      ->capture_default_str();
  app.add_option("--pick-threshold", options.threshold,
                 "Accumulated opacity at which a pick's ray stops, in (0, 1)")
      ->capture_default_str();
}

std::vector<PixelPick> parse_picks(const PickCliOptions& options,
                                   engine::labels::Label first_label) {
  if (options.picks.empty()) return {};
  int width = 0, height = 0;
  parse_size(options.size, "--pick-size", width, height);
  parse_view(options.view);
  if (!(options.threshold > 0.0 && options.threshold < 1.0)) {
    throw InputError("--pick-threshold", "must lie in (0, 1)");
  }
  std::vector<PixelPick> picks;
  for (const std::string& text : options.picks) {
    PixelPick pick;
    pick.label = first_label + static_cast<engine::labels::Label>(picks.size());
    const std::size_t comma = text.find(',');
    const std::size_t colon = text.find(':');
    if (comma == std::string::npos || (colon != std::string::npos && colon < comma)) {
      throw InputError("--pick", "expected PX,PY[:LABEL], got '" + text + "'");
    }
    pick.x = parse_int(text.substr(0, comma), "pixels", text);
    pick.y =
        parse_int(text.substr(comma + 1, colon == std::string::npos ? colon : colon - comma - 1),
                  "pixels", text);
    if (colon != std::string::npos) {
      pick.label = parse_int(text.substr(colon + 1), "label", text);
      if (pick.label <= 0 || pick.label > engine::labels::kMaxLabel) {
        throw InputError("--pick", "label in '" + text + "' must lie in [1, " +
                                       std::to_string(engine::labels::kMaxLabel) + "]");
      }
    }
    if (pick.x < 0 || pick.x >= width || pick.y < 0 || pick.y >= height) {
      throw InputError("--pick", "pixel '" + text + "' is outside the " + std::to_string(width) +
                                     "x" + std::to_string(height) + " image (--pick-size)");
    }
    picks.push_back(pick);
  }
  return picks;
}

std::vector<engine::labels::Seed> seeds_from_picks(const engine::RawVolume& intensity,
                                                   const std::string& volume_spec,
                                                   const PickCliOptions& options,
                                                   const std::vector<PixelPick>& picks) {
  if (picks.empty()) return {};
  int width = 0, height = 0;
  parse_size(options.size, "--pick-size", width, height);
  const std::vector<double> view = parse_view(options.view);
  const bool is_file = std::filesystem::exists(volume_spec);
  const render::TransferFunction transfer =
      render::TransferFunction::from_spec(transfer_spec_for(options.transfer, volume_spec));
  // Density as `hapvox render` maps it by default: a generator's intensities are densities,
  // a file's are thresholded at Otsu's value.
  const double otsu = is_file ? engine::otsu_threshold(intensity) : 0.0;
  const auto opacity = [&](float value) {
    const double density =
        is_file ? (value >= otsu ? 1.0 : 0.0) : std::clamp(static_cast<double>(value), 0.0, 1.0);
    const int entry =
        static_cast<int>(std::lround(density * (render::TransferFunction::kSize - 1)));
    return transfer.entry(entry)[3];
  };
  const Eigen::Vector3d lo = intensity.origin_mm - 0.5 * intensity.spacing_mm;
  const Eigen::Vector3d hi =
      intensity.origin_mm + (intensity.dims.cast<double>() - Eigen::Vector3d::Constant(0.5))
                                .cwiseProduct(intensity.spacing_mm);
  const render::OrbitCamera camera = render::OrbitCamera::framing(lo, hi, view[0], view[1]);
  std::vector<engine::labels::Seed> seeds;
  for (const PixelPick& pick : picks) {
    const auto hit = engine::labels::pick_voxel(intensity, camera.eye_mm(),
                                                camera.pixel_ray(pick.x, pick.y, width, height),
                                                opacity, options.threshold);
    if (!hit) {
      char problem[200];
      std::snprintf(problem, sizeof problem,
                    "pixel %d,%d sees nothing: the accumulated opacity along its ray stays "
                    "below %g",
                    pick.x, pick.y, options.threshold);
      throw InputError("--pick", problem);
    }
    engine::labels::Seed seed;
    seed.point_mm =
        intensity.origin_mm + hit->voxel.cast<double>().cwiseProduct(intensity.spacing_mm);
    seed.label = pick.label;
    seeds.push_back(seed);
  }
  return seeds;
}

}  // namespace hapvox::cli
