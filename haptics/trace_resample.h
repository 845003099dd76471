#pragma once
// Resampling a trace read from a file onto the loop's clock (haptics/trace.h: resample), with
// its errors naming the file, and its ticks budgeted before anything is allocated.

#include <string>

#include "haptics/trace.h"

namespace hapvox::haptics {

/// resample(trace, options), its problems with the trace named as InputError(source, ...):
/// too few samples, times that do not increase, and a time span that at options.rate_hz
/// makes more ticks than --max-trace-rows allows (engine/input_limits.h), refused before any
/// tick is allocated. A rate or gap that is not positive stays InputError("resample", ...).
ResampledTrace resample(const Trace& trace, const ResampleOptions& options,
                        const std::string& source);

}  // namespace hapvox::haptics
