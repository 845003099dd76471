// hapvox::Trace: probe traces behind the public API (include/hapvox/trace.h).

#include <cmath>
#include <filesystem>

#include "api/internal.h"
#include "engine/errors.h"
#include "hapvox/trace.h"
#include "tools/cli.h"

namespace hapvox {

Trace Trace::load(const std::string& path, const TraceColumns& columns) {
  cli::TraceFlags flags;  // --time-col, --pos-cols, units: checked as the CLI checks them
  flags.time_col = columns.time;
  flags.pos_cols = columns.position[0] + "," + columns.position[1] + "," + columns.position[2];
  flags.time_unit = columns.time_unit;
  flags.pos_unit = columns.position_unit;
  return Trace(std::make_shared<Impl>(Impl{haptics::read_trace(path, flags.columns())}));
}

Trace Trace::from_samples(const std::vector<double>& time_s,
                          const std::vector<std::array<double, 3>>& position_mm) {
  if (time_s.size() != position_mm.size()) {
    throw InputError("trace", std::to_string(time_s.size()) + " times but " +
                                  std::to_string(position_mm.size()) + " positions");
  }
  if (time_s.size() < 2) throw InputError("trace", "needs at least two samples");
  haptics::Trace trace;
  for (std::size_t i = 0; i < time_s.size(); ++i) {
    const auto& p = position_mm[i];
    if (!std::isfinite(time_s[i]) || !std::isfinite(p[0]) || !std::isfinite(p[1]) ||
        !std::isfinite(p[2])) {
      throw InputError("trace", "sample " + std::to_string(i) + " is not finite");
    }
    if (i > 0 && !(time_s[i] > time_s[i - 1])) {
      throw InputError("trace", "time is not strictly increasing at sample " + std::to_string(i));
    }
    trace.time_s.push_back(time_s[i]);
    trace.position_mm.emplace_back(p[0], p[1], p[2]);
  }
  return Trace(std::make_shared<Impl>(Impl{std::move(trace)}));
}

std::size_t Trace::size() const { return impl_->trace.time_s.size(); }

std::vector<double> Trace::time_s() const { return impl_->trace.time_s; }

std::vector<std::array<double, 3>> Trace::position_mm() const {
  std::vector<std::array<double, 3>> out;
  out.reserve(impl_->trace.position_mm.size());
  for (const auto& p : impl_->trace.position_mm) out.push_back({p.x(), p.y(), p.z()});
  return out;
}

std::vector<ToolSample> Trace::resampled(double rate_hz, double max_gap_s) const {
  const haptics::ResampledTrace r =
      haptics::resample(impl_->trace, api::loop_clock(rate_hz, max_gap_s));
  std::vector<ToolSample> out(r.time_s.size());
  for (std::size_t k = 0; k < out.size(); ++k) {
    out[k].time_s = r.time_s[k];
    out[k].position_mm = {r.position_mm[k].x(), r.position_mm[k].y(), r.position_mm[k].z()};
    out[k].holding = r.holding[k] != 0;
  }
  return out;
}

void Trace::save(const std::string& path) const {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".h5" || ext == ".hdf5") {
    haptics::write_h5_trace(impl_->trace, path);
  } else {
    haptics::write_csv_trace(impl_->trace, path);
  }
}

}  // namespace hapvox
