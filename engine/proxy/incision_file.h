#pragma once
// The incision file (TOML, docs/formats.md#incision-file): a cut for the proxy-FEM model
// (engine/proxy/incised_proxy.h), as a polyline swept along a vector or as triangles, the
// width it is opened by, and optionally when a replay makes it.
//
//   width_mm = 6.0
//   polyline_mm = [[-5.0, 27.4, 52.0], [52.0, 27.4, 52.0]]   # with sweep_mm
//   sweep_mm = [0.0, 0.0, -32.0]
//   # or: triangles_mm = [[[x, y, z], [x, y, z], [x, y, z]], ...]
//   at_s = 1.5   # replay: the cut is made at this time of the trace (absent: from the start)
//
// World millimetres, the volume's frame (as the materials file's regions).

#include <optional>
#include <string>
#include <string_view>

#include "engine/fem/incision.h"

namespace hapvox::engine::proxy {

struct IncisionFile {
  fem::CutSurface cut;
  double width_mm = 0.0;
  std::optional<double> at_s;
  std::string source;
};

/// Parses the text of an incision file; errors are InputError("source:line", problem), one
/// line each: TOML syntax, an unknown key, a missing or wrong-typed value, a width or time
/// that is not positive (width) or not >= 0 (time), both or neither of polyline_mm and
/// triangles_mm, sweep_mm without a polyline, and the geometry errors of swept_polyline.
IncisionFile parse_incision(std::string_view text, const std::string& source);

/// Reads and parses the file at `path` (InputError(path, ...) when it cannot be read).
IncisionFile read_incision(const std::string& path);

}  // namespace hapvox::engine::proxy
