#pragma once
// Transfer functions: density in [0, 1] -> colour and opacity, as a 256-entry lookup
// table. Opacity is per voxel of path (the renderer corrects it for its slice spacing).
//
// File format (text): one control point a line, "density r g b a", all in [0, 1],
// densities strictly increasing, at least two points; '#' starts a comment. Between
// points the table is linear; below the first and above the last it is constant.

#include <array>
#include <string>
#include <vector>

namespace hapvox::render {

struct ControlPoint {
  float density = 0, r = 0, g = 0, b = 0, a = 0;
};

class TransferFunction {
 public:
  static constexpr int kSize = 256;

  /// From control points (validated as a file's would be; `source` names them in errors).
  TransferFunction(const std::vector<ControlPoint>& points, const std::string& source);

  /// "clay", "ct-bone", "ct-soft", or a file path. Throws InputError naming the preset or
  /// the file (and line) and the problem.
  static TransferFunction from_spec(const std::string& spec);
  /// Names of the presets, for help texts.
  static std::vector<std::string> preset_names();

  /// RGBA (straight alpha) at entry i, density i / (kSize - 1).
  const std::array<float, 4>& entry(int i) const { return table_[i]; }
  const std::array<std::array<float, 4>, kSize>& table() const { return table_; }
  /// Lowest density with non-zero opacity (empty-space skipping below it).
  float first_visible_density() const { return first_visible_; }

 private:
  std::array<std::array<float, 4>, kSize> table_{};
  float first_visible_ = 1.0f;
};

/// Reads a transfer-function file. Throws InputError("PATH:LINE", ...) on a bad line.
TransferFunction read_transfer_function(const std::string& path);

}  // namespace hapvox::render
