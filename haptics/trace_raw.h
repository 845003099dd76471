#pragma once
// What every trace reader shares (trace.cc, trace_h3d.cc, trace_h5.cc, trace_resample.cc): samples
// as read, in file units, and the checks and unit scaling that make them a Trace.

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
/// "cannot open file") when it cannot be read, InputError(path, "holds N MB, over the limit
/// ...") past --max-input-mb (engine/input_limits.h), before it is read.
std::string read_trace_text(const std::string& path);

/// InputError(source, "time scale must be positive and finite ...") (or the position scale's)
/// when `columns`' unit scales are not.
void check_scales(const std::string& source, const TraceColumns& columns);

/// The shortest text that reads back as `v` ("0.5", not "0.50000000000000000").
std::string format_double(double v);

/// InputError(source, "trace has N times but M positions") when the trace's vectors differ
/// in length.
void check_trace_shape(const Trace& trace, const std::string& source);

}  // namespace hapvox::haptics::detail
