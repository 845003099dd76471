#pragma once
// Probe traces: tool positions over time in the device's frame (seconds, millimetres), read
// from a file or made from your own samples, and resampled onto the force loop's clock as
// `hapvox replay` does.

#include <array>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace hapvox {

/// One device sample: the tool centre in the device frame, at a time.
struct ToolSample {
  double time_s = 0.0;
  std::array<double, 3> position_mm = {0.0, 0.0, 0.0};
  /// The device holds the tool here (a gap in a trace): recorded, the force still computed.
  bool holding = false;
};

/// Which columns hold time and position (`--time-col`, `--pos-cols`) and their units
/// (`--time-unit` s|ms|us, `--pos-unit` mm|m|cm|um).
struct TraceColumns {
  std::string time = "t";
  std::array<std::string, 3> position = {"x", "y", "z"};
  std::string time_unit = "s";
  std::string position_unit = "mm";
};

class Trace {
 public:
  /// Reads a CSV, HDF5 (.h5/.hdf5) or H3D DeviceLog trace. Throws InputError naming the file
  /// (and the CSV line) and the problem.
  static Trace load(const std::string& path, const TraceColumns& columns = {});
  /// A trace from samples: strictly increasing finite times, finite positions, at least two.
  /// Throws InputError("trace", ...) otherwise.
  static Trace from_samples(const std::vector<double>& time_s,
                            const std::vector<std::array<double, 3>>& position_mm);

  std::size_t size() const;
  std::vector<double> time_s() const;
  std::vector<std::array<double, 3>> position_mm() const;

  /// The trace on a loop's clock, as a replay reads it: tick k at time_s[0] + k / rate_hz,
  /// linearly interpolated; across a gap longer than max_gap_s the tool holds (holding).
  std::vector<ToolSample> resampled(double rate_hz = 1000.0, double max_gap_s = 0.05) const;

  /// Writes columns t,x,y,z as CSV, or as HDF5 datasets for .h5/.hdf5.
  void save(const std::string& path) const;

  struct Impl;
  const Impl& impl() const { return *impl_; }

 private:
  explicit Trace(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}
  std::shared_ptr<const Impl> impl_;
};

}  // namespace hapvox
