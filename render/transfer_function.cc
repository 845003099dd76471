#include "render/transfer_function.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include "engine/errors.h"

namespace hapvox::render {
namespace {

std::vector<ControlPoint> preset_points(const std::string& name) {
  if (name == "clay") {
    // Terracotta: anything above a tenth of the normal density is clay, nearly opaque.
    return {{0.00f, 0.80f, 0.45f, 0.30f, 0.0f},
            {0.10f, 0.80f, 0.45f, 0.30f, 0.0f},
            {0.35f, 0.82f, 0.50f, 0.35f, 0.6f},
            {1.00f, 0.85f, 0.55f, 0.40f, 0.95f}};
  }
  if (name == "ct-bone") {
    // Dense structures opaque ivory, the rest invisible.
    return {{0.00f, 0.0f, 0.0f, 0.0f, 0.0f},
            {0.30f, 0.9f, 0.85f, 0.75f, 0.0f},
            {0.50f, 0.95f, 0.92f, 0.85f, 0.5f},
            {1.00f, 1.0f, 1.0f, 0.95f, 0.95f}};
  }
  if (name == "ct-soft") {
    // Soft tissue faint red, denser material whiter and more opaque.
    return {{0.00f, 0.0f, 0.0f, 0.0f, 0.0f},
            {0.10f, 0.8f, 0.3f, 0.25f, 0.0f},
            {0.25f, 0.85f, 0.35f, 0.3f, 0.05f},
            {0.50f, 0.9f, 0.7f, 0.6f, 0.2f},
            {1.00f, 1.0f, 1.0f, 0.95f, 0.9f}};
  }
  return {};
}

}  // namespace

TransferFunction::TransferFunction(const std::vector<ControlPoint>& points,
                                   const std::string& source) {
  if (points.size() < 2) throw InputError(source, "needs at least two control points");
  for (std::size_t i = 0; i < points.size(); ++i) {
    const ControlPoint& p = points[i];
    for (float v : {p.density, p.r, p.g, p.b, p.a}) {
      if (!std::isfinite(v) || v < 0.0f || v > 1.0f) {
        throw InputError(source,
                         "control point " + std::to_string(i + 1) + ": values must lie in [0, 1]");
      }
    }
    if (i > 0 && !(p.density > points[i - 1].density)) {
      throw InputError(
          source, "control point " + std::to_string(i + 1) + ": densities must increase strictly");
    }
  }
  std::size_t k = 0;
  for (int i = 0; i < kSize; ++i) {
    const float d = static_cast<float>(i) / (kSize - 1);
    while (k + 1 < points.size() && points[k + 1].density < d) ++k;
    const ControlPoint& a = points[k];
    const ControlPoint& b = points[std::min(k + 1, points.size() - 1)];
    float t = 0.0f;
    if (d <= a.density) {
      t = 0.0f;
    } else if (d >= b.density) {
      t = 1.0f;
    } else {
      t = (d - a.density) / (b.density - a.density);
    }
    table_[i] = {a.r + t * (b.r - a.r), a.g + t * (b.g - a.g), a.b + t * (b.b - a.b),
                 a.a + t * (b.a - a.a)};
  }
  for (int i = 0; i < kSize; ++i) {
    if (table_[i][3] > 0.0f) {
      first_visible_ = static_cast<float>(std::max(0, i - 1)) / (kSize - 1);
      break;
    }
  }
}

std::vector<std::string> TransferFunction::preset_names() { return {"clay", "ct-bone", "ct-soft"}; }

TransferFunction TransferFunction::from_spec(const std::string& spec) {
  const std::vector<ControlPoint> preset = preset_points(spec);
  if (!preset.empty()) return TransferFunction(preset, spec);
  if (std::ifstream(spec).good()) return read_transfer_function(spec);
  throw InputError(spec, "not a transfer-function preset (clay, ct-bone, ct-soft) or a file");
}

TransferFunction read_transfer_function(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "cannot be opened");
  std::vector<ControlPoint> points;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream fields(line);
    ControlPoint p;
    if (!(fields >> p.density)) {
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;  // blank
      throw InputError(path + ":" + std::to_string(number),
                       "expected 'density r g b a' (five numbers)");
    }
    std::string rest;
    if (!(fields >> p.r >> p.g >> p.b >> p.a) || (fields >> rest)) {
      throw InputError(path + ":" + std::to_string(number),
                       "expected 'density r g b a' (five numbers)");
    }
    points.push_back(p);
  }
  return TransferFunction(points, path);
}

}  // namespace hapvox::render
