#include "haptics/trace_resample.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "engine/check.h"
#include "engine/errors.h"
#include "engine/input_limits.h"
#include "haptics/trace_raw.h"

namespace hapvox::haptics {

using detail::check_trace_shape;
using detail::format_double;

ResampledTrace resample(const Trace& trace, const ResampleOptions& options) {
  return resample(trace, options, "resample");
}

ResampledTrace resample(const Trace& trace, const ResampleOptions& options,
                        const std::string& source) {
  if (!(options.rate_hz > 0.0) || !std::isfinite(options.rate_hz)) {
    throw InputError("resample",
                     "rate must be positive (got " + format_double(options.rate_hz) + ")");
  }
  if (!(options.max_gap_s > 0.0)) {
    throw InputError("resample",
                     "max gap must be positive (got " + format_double(options.max_gap_s) + ")");
  }
  check_trace_shape(trace, source);
  const std::vector<double>& t = trace.time_s;
  const std::vector<Vec3d>& p = trace.position_mm;
  const std::size_t n = t.size();
  if (n < 2) throw InputError(source, "need at least 2 samples, found " + std::to_string(n));
  for (std::size_t i = 1; i < n; ++i) {
    if (!(t[i] > t[i - 1])) {
      throw InputError(source, "times must strictly increase (index " + std::to_string(i) + ")");
    }
  }

  ResampledTrace out;
  out.rate_hz = options.rate_hz;
  const double t0 = t.front();
  // The small slack keeps a tick that lands on the last sample up to rounding (e.g. a 1 s
  // trace at 1 kHz has 1001 ticks even if (t_end - t0) * rate is 999.9999999999).
  const double last_k = std::floor((t.back() - t0) * options.rate_hz + 1e-9);
  engine::check_trace_rows(last_k + 1, source,
                           "its time span of " + format_double(t.back() - t0) + " s at " +
                               format_double(options.rate_hz) + " Hz makes");
  const std::size_t ticks = static_cast<std::size_t>(last_k) + 1;
  out.time_s.reserve(ticks);
  out.position_mm.reserve(ticks);
  out.holding.reserve(ticks);
  const std::vector<Eigen::Quaterniond>& q = trace.orientation;
  const bool turning = !q.empty();
  if (turning) {
    HAPVOX_CHECK_EQ(q.size(), n);
    out.orientation.reserve(ticks);
  }

  for (std::size_t i = 0; i + 1 < n; ++i) {
    const double dt = t[i + 1] - t[i];
    if (dt > options.max_gap_s) {
      ++out.gap_count;
      out.held_time_s += dt;
    }
  }

  std::size_t j = 0;  // current step: t[j] <= tick < t[j + 1]
  for (std::size_t k = 0; k < ticks; ++k) {
    // k / rate, not a running sum, so long traces do not drift.
    const double tick = t0 + static_cast<double>(k) / options.rate_hz;
    while (j + 2 < n && t[j + 1] <= tick) ++j;
    const double dt = t[j + 1] - t[j];
    Vec3d position;
    std::uint8_t holding = 0;
    double u = 0.0;  // along the step j -> j + 1
    if (tick >= t[j + 1]) {
      u = 1.0;  // only at (or within rounding past) the last sample
      position = p[j + 1];
    } else if (dt > options.max_gap_s) {
      position = p[j];
      holding = tick > t[j] ? 1 : 0;
    } else {
      u = std::clamp((tick - t[j]) / dt, 0.0, 1.0);
      position = p[j] + u * (p[j + 1] - p[j]);
    }
    out.time_s.push_back(tick);
    out.position_mm.push_back(position);
    out.holding.push_back(holding);
    // The orientation turns along the shorter arc between the samples, as the position
    // moves along the straight line.
    if (turning) out.orientation.push_back(q[j].slerp(u, q[j + 1]));
  }
  return out;
}

}  // namespace hapvox::haptics
