#pragma once
// Probe traces: reading (CSV, HDF5, H3D DeviceLog text logs: haptics/trace_h3d.h) and
// writing (CSV, HDF5), resampling to the loop rate, the device-to-volume transform, and the
// synthetic trace generator behind `hapvox trace make`.
//
// Units inside hapvox: seconds and millimetres. Every user-facing failure throws
// hapvox::InputError naming the file and the problem (with the CSV line number).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace hapvox::haptics {

using Vec3d = Eigen::Vector3d;

/// Which columns (CSV header names, or HDF5 1-D dataset names at the file root) hold time
/// and position, and the units they are in.
struct TraceColumns {
  std::string time = "t";
  std::array<std::string, 3> position = {"x", "y", "z"};
  double seconds_per_time_unit = 1.0;  // e.g. 1e-3 when the time column is in ms
  double mm_per_position_unit = 1.0;   // e.g. 1000 when positions are in metres
  /// The stylus orientation as a quaternion's W,X,Y,Z columns (any scale: normalised on
  /// reading); all empty (the default) when the trace has none.
  std::array<std::string, 4> orientation = {};
  bool has_orientation() const { return !orientation[0].empty(); }
};

/// A trace as recorded: strictly increasing, finite times (s) and finite positions (mm),
/// in device space. At least two samples.
struct Trace {
  std::vector<double> time_s;
  std::vector<Vec3d> position_mm;
  /// The stylus orientation (unit quaternions, device space), one per sample; empty when
  /// the trace has none. Kept for 6-DoF tools: the 3-DoF sphere does not turn.
  std::vector<Eigen::Quaterniond> orientation;
};

/// Reads a CSV (header row; comma separated; extra columns ignored), HDF5 (.h5/.hdf5, by
/// extension) or H3D DeviceLog text trace (its header row names DeviceLog fields: the
/// columns and units of `columns` do not apply, haptics/trace_h3d.h).
Trace read_trace(const std::string& path, const TraceColumns& columns = {});
Trace read_csv_trace(const std::string& path, const TraceColumns& columns = {});
/// A CSV trace's text (after a byte-order mark); `source` names it in errors.
Trace parse_csv_trace(const std::string& text, const std::string& source,
                      const TraceColumns& columns = {});
Trace read_h5_trace(const std::string& path, const TraceColumns& columns = {});

/// Writes columns t,x,y,z (seconds, mm). Written to PATH.partial, then renamed.
void write_csv_trace(const Trace& trace, const std::string& path);
/// Writes 1-D float64 datasets t, x, y, z at the root. Written to PATH.partial, then renamed.
void write_h5_trace(const Trace& trace, const std::string& path);

/// Device space -> volume space: p_volume = offset + rotation * (scale * p_device).
struct DeviceTransform {
  double scale = 1.0;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Vec3d offset_mm = Vec3d::Zero();

  Vec3d apply(const Vec3d& p_device_mm) const {
    return offset_mm + rotation * (scale * p_device_mm);
  }
};

/// Rotation from Euler angles in degrees, applied about x, then y, then z.
Eigen::Matrix3d rotation_from_euler_deg(const Vec3d& xyz_deg);

/// The uniform-scale transform (no rotation) that fits the trace's bounding box into
/// [box_min, box_max] shrunk by `margin_fraction` of its size on each side, centred.
DeviceTransform fit_trace_into_box(const Trace& trace, const Vec3d& box_min_mm,
                                   const Vec3d& box_max_mm, double margin_fraction = 0.05);

struct ResampleOptions {
  double rate_hz = 1000.0;
  double max_gap_s = 0.05;  // a step between samples longer than this is a gap
};

/// The trace on the loop's clock: tick k at time_s[0] + k / rate_hz, up to the last
/// sample. Linear interpolation between samples; across a gap the tool holds at the
/// sample before the gap (holding[k] = 1).
struct ResampledTrace {
  double rate_hz = 1000.0;
  std::vector<double> time_s;
  std::vector<Vec3d> position_mm;
  std::vector<std::uint8_t> holding;
  std::vector<Eigen::Quaterniond> orientation;  // slerped per tick; empty when none
  int gap_count = 0;                            // number of gaps found
  double held_time_s = 0;                       // total time spent holding across gaps
};

ResampledTrace resample(const Trace& trace, const ResampleOptions& options = {});

/// Shapes for synthetic traces.
enum class TraceShape { kPress, kPressRelease, kStroke, kCircle };

/// Parses "press", "press-release", "stroke", "circle"; throws InputError(source, ...).
TraceShape parse_trace_shape(const std::string& name, const std::string& source);

/// A synthetic trace. Every shape starts at `start_mm`, moves `travel_mm` along
/// `direction` (normalised) at `speed_mm_s`, then:
///   press          holds for `hold_s`;
///   press-release  holds for `hold_s`, then returns to the start at the same speed;
///   stroke         moves `stroke_length_mm` along `lateral` (made perpendicular to
///                  direction), then returns along -direction by travel_mm;
///   circle         runs one circle of `radius_mm` in the plane perpendicular to
///                  direction, starting and ending at the bottom point, then returns.
/// Sampled at `rate_hz`.
struct TraceMakeOptions {
  TraceShape shape = TraceShape::kPressRelease;
  Vec3d start_mm = Vec3d::Zero();
  Vec3d direction = Vec3d(0, 0, -1);
  Vec3d lateral = Vec3d(1, 0, 0);
  double travel_mm = 10.0;
  double speed_mm_s = 10.0;
  double hold_s = 0.5;
  double stroke_length_mm = 20.0;
  double radius_mm = 10.0;
  double rate_hz = 1000.0;
};

/// Throws InputError("trace make", ...) on non-positive speed/rate/travel, zero direction.
Trace make_trace(const TraceMakeOptions& options);

}  // namespace hapvox::haptics
