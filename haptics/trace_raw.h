#pragma once
// What every trace reader shares (trace.cc, trace_h3d.cc): samples as read, in file units,
// and the checks and unit scaling that make them a Trace.

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "haptics/trace.h"

namespace hapvox::haptics::detail {

/// Raw values as read (file units) with a way to name sample i ("line 7", "index 6").
struct RawTrace {
  std::vector<double> time;
  std::vector<std::array<double, 3>> position;
  std::vector<std::array<double, 4>> orientation;  // w, x, y, z; empty when none
  std::function<std::string(std::size_t)> where;
  std::string kind;  // "column", "dataset" or "field"
};

/// The checks shared by every reader: finite values, increasing time, two samples, a
/// non-zero orientation; then unit scaling (`columns`' scales; its names name the values in
/// messages) and normalised orientations. Throws InputError(source, "line 7: ...").
Trace finish_trace(const std::string& source, const TraceColumns& columns, const RawTrace& raw);

/// The text of a trace file with a UTF-8 byte-order mark removed; InputError(path,
/// "cannot open file") when it cannot be read.
std::string read_trace_text(const std::string& path);

}  // namespace hapvox::haptics::detail
