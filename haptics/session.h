#pragma once
// The session file: an HDF5 file, readable by h5py, holding one row per force tick and the
// configuration and versions as attributes. Schema in docs/formats.md.
//
// Written incrementally to PATH.partial (flushed every `flush_every_ticks`, ~1 s at
// 1 kHz, so a killed process loses at most that) and renamed to PATH by close(): a file at
// PATH is always a complete session, and an existing PATH is replaced only on success.

#include <hdf5.h>

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace hapvox::engine::io {
class OutputFile;
}  // namespace hapvox::engine::io

namespace hapvox::haptics {

using Vec3d = Eigen::Vector3d;

/// What one force tick did.
struct TickRecord {
  double time_s = 0.0;
  Vec3d device_position_mm = Vec3d::Zero();  // trace position (device space, resampled)
  Vec3d tool_position_mm = Vec3d::Zero();    // tool centre in volume space
  Vec3d force_n = Vec3d::Zero();             // force sent (finite, clamped, ramped)
  double force_scale = 0.0;                  // the ramp factor it was sent with (ForceRamp)
  Vec3d displacement_mm = Vec3d::Zero();     // u = x_n - x0 of the elastic model
  // The stylus orientation (w,x,y,z, device space), where the device reports one.
  std::array<double, 4> device_orientation_wxyz = {1.0, 0.0, 0.0, 0.0};
  double contact_area_mm2 = 0.0;
  std::uint8_t contact = 0;
  std::uint8_t holding = 0;           // trace gap: tool held
  std::uint8_t clamped = 0;           // force magnitude limited to the device maximum
  std::uint8_t motion_fault = 0;      // the device sample jumped (MotionGuard): not used
  std::int64_t device_sequence = -1;  // the device sample used: trace tick, packet sequence
  std::int64_t compute_ns = 0;
  std::int64_t scheduled_ns = 0;  // deadline of the tick, from the start of the run
  std::int64_t start_ns = 0;      // when its computation started (lockstep: = scheduled)
  std::uint8_t watchdog = 0;      // realtime: the tick overran; the force ramps down next
  // Plasticity (zeros when off).
  double strain = 0.0;             // total strain of the contact
  double stress_measure_pa = 0.0;  // s = E |u| / L
  std::uint8_t zone = 0;           // engine::PlasticZone
  std::uint8_t plastic_event = 0;  // a surface change was emitted this tick
  // Relaxation (zeros when off).
  std::int64_t queue_depth = 0;
  // The newest plastic event (SurfaceChange::event) whose deletion the field this tick read
  // includes: -1 before the first. Not written to the session (bench sculpt reads it).
  std::int64_t published_event = -1;
  std::int64_t deleted_voxels = 0;  // this tick
  std::int64_t relaxed_voxels = 0;  // this tick
  std::int64_t total_mass_units = 0;
};

class SessionWriter {
 public:
  /// Creates PATH.partial. Throws hapvox::InputError(path, ...) if it cannot.
  explicit SessionWriter(std::string path, std::size_t flush_every_ticks = 1000);
  ~SessionWriter();
  SessionWriter(const SessionWriter&) = delete;
  SessionWriter& operator=(const SessionWriter&) = delete;

  /// Root attributes (configuration, versions, summary).
  void set_attribute(const std::string& name, const std::string& value);
  void set_attribute(const std::string& name, double value);
  void set_attribute(const std::string& name, std::int64_t value);
  void set_attribute(const std::string& name, const Vec3d& value);

  /// Writes a one-off 1-D integer dataset (e.g. "timing/relax_slice_ns") with a unit.
  void write_array(const std::string& path, const std::vector<std::int64_t>& values,
                   const char* unit);

  /// Writes a one-off float64 dataset of shape `dims` (row-major values; an empty
  /// dimension allowed), e.g. "fem/displacement_mm" of (FEM steps, vertices, 3), with a unit.
  void write_array(const std::string& path, const std::vector<double>& values,
                   const std::vector<std::size_t>& dims, const char* unit);

  /// The open file, for writers of whole groups (e.g. the proxy mesh); not after close().
  hid_t file_handle() const { return file_; }

  /// Adds the /device_orientation column (ticks x 4: the stylus quaternion w,x,y,z of each
  /// row), for a device that reports one. Before the first append().
  void record_orientation();

  /// Buffers the row; writes and flushes the file every flush_every_ticks rows.
  void append(const TickRecord& row);
  /// Writes what is buffered, marks the file complete and renames it to PATH.
  void close();
  /// Deletes PATH.partial (used when a run fails before producing anything useful).
  void abandon();

  const std::string& path() const { return path_; }
  std::size_t rows_written() const { return rows_written_; }

 private:
  void flush_rows();
  void close_datasets();
  void write_column(hid_t dataset, hid_t mem_type, const void* data, std::size_t columns);

  std::string path_;
  std::unique_ptr<engine::io::OutputFile> output_;
  std::size_t flush_every_;
  hid_t file_ = -1;
  struct Datasets {
    hid_t time_s, device_position_mm, tool_position_mm, force_n, displacement_mm, contact_area_mm2,
        contact, holding, clamped, motion_fault, compute_ns, strain, stress_pa, zone, plastic_event,
        queue_depth, deleted_voxels, relaxed_voxels, total_mass_units, scheduled_ns, start_ns,
        lateness_ns, watchdog, force_scale, device_sequence;
    hid_t device_orientation = -1;  // record_orientation()'s
  } ds_{};
  std::vector<TickRecord> buffer_;
  std::size_t rows_written_ = 0;
  bool closed_ = false;
};

/// Library versions as "name version" pairs, for session attributes and `hapvox --version`.
std::vector<std::pair<std::string, std::string>> library_versions();

}  // namespace hapvox::haptics

namespace hapvox::haptics {

/// What `hapvox info` shows of a session file.
struct SessionInfo {
  std::size_t rows = 0;
  bool complete = false;
  std::vector<std::pair<std::string, std::string>> attributes;  // name, value as text
  std::vector<std::string> datasets;                            // paths, e.g. "/force_n"
};

/// Opens an HDF5 file as hapvox opens sessions: read-only (or read-write), also when a killed
/// run left it marked as open for write, and also while a run writes it. A negative id if it
/// cannot. The caller closes it (H5Fclose).
hid_t open_session_for_reading(const std::string& path, bool read_write = false);

/// Opens an HDF5 session for reading. Throws InputError(path, ...) if it is not one.
SessionInfo read_session_info(const std::string& path);

/// A numeric dataset of a session (or any HDF5 file), flattened row-major, as doubles, and
/// its shape into `dims` when given. Throws InputError(path, ...) when it is missing or
/// not numeric (strings, compounds).
std::vector<double> read_session_column(const std::string& path, const std::string& dataset,
                                        std::vector<std::size_t>* dims = nullptr);

/// True when the file starts with the HDF5 signature.
bool is_hdf5_file(const std::string& path);

}  // namespace hapvox::haptics
