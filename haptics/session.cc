#include "haptics/session.h"

#include <openvdb/version.h>

#include <Eigen/Core>
#include <algorithm>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "engine/check.h"
#include "engine/errors.h"
#include "engine/version.h"
#include "haptics/hdf5_id.h"

namespace hapvox::haptics {
namespace {

// Rows per HDF5 chunk: one second at 1 kHz.
constexpr hsize_t kChunkRows = 1024;

// A scalar string attribute on an object.
void set_string_attribute(hid_t object, const char* name, const char* value) {
  const hid_t str_type = H5Tcopy(H5T_C_S1);
  H5Tset_size(str_type, std::strlen(value) + 1);
  const hid_t scalar = H5Screate(H5S_SCALAR);
  const hid_t attr = H5Acreate2(object, name, str_type, scalar, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(attr, str_type, value);
  H5Aclose(attr);
  H5Sclose(scalar);
  H5Tclose(str_type);
}

hid_t create_column(hid_t file, const char* name, hid_t file_type, hsize_t columns,
                    const char* units) {
  const int rank = columns == 1 ? 1 : 2;
  const hsize_t dims[2] = {0, columns};
  const hsize_t max_dims[2] = {H5S_UNLIMITED, columns};
  const hsize_t chunk[2] = {kChunkRows, columns};
  const hid_t space = H5Screate_simple(rank, dims, max_dims);
  const hid_t props = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(props, rank, chunk);
  // Groups on the path ("render/frame_ns") are made as needed.
  const hid_t link_props = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(link_props, 1);
  // Rows arrive in order and a chunk is done once the next one starts, so two chunks of
  // cache suffice. HDF5's default (1 MiB per dataset) kept up to ~0.5-1 MiB of finished
  // chunks in each of the ~23 columns: a session's memory grew by ~11 MB over 10 minutes.
  const hid_t access = H5Pcreate(H5P_DATASET_ACCESS);
  H5Pset_chunk_cache(access, 101, 2 * kChunkRows * columns * H5Tget_size(file_type), 1.0);
  const hid_t dataset = H5Dcreate2(file, name, file_type, space, link_props, props, access);
  H5Pclose(access);
  H5Pclose(link_props);
  H5Pclose(props);
  H5Sclose(space);
  HAPVOX_CHECK(dataset >= 0);
  if (units != nullptr) set_string_attribute(dataset, "units", units);
  return dataset;
}

void write_root_attribute(hid_t file, const std::string& name, hid_t type, hid_t space,
                          const void* data) {
  if (H5Aexists(file, name.c_str()) > 0) H5Adelete(file, name.c_str());
  const hid_t attr = H5Acreate2(file, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT);
  HAPVOX_CHECK(attr >= 0);
  H5Awrite(attr, type, data);
  H5Aclose(attr);
}

}  // namespace

SessionWriter::SessionWriter(std::string path, std::size_t flush_every_ticks)
    : path_(std::move(path)), flush_every_(flush_every_ticks) {
  HAPVOX_CHECK_GT(flush_every_, 0u);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  output_ = std::make_unique<engine::io::OutputFile>(path_);  // PATH.partial, locked
  // The HDF5 1.10 file format (readable by HDF5 >= 1.10: h5py, ParaView)
  // indexes an appended column's chunks with an extensible array; the 1.8 format's B-tree
  // index grew the process by another ~5 MB over a 10-minute session.
  const hid_t access = H5Pcreate(H5P_FILE_ACCESS);
  H5Pset_libver_bounds(access, H5F_LIBVER_V110, H5F_LIBVER_V110);
  try {
    file_ = create_hdf5_output(*output_, access);
  } catch (const InputError&) {
    H5Pclose(access);
    output_->discard();
    throw;
  }
  H5Pclose(access);
  ds_.time_s = create_column(file_, "time_s", H5T_IEEE_F64LE, 1, "s");
  ds_.device_position_mm = create_column(file_, "device_position_mm", H5T_IEEE_F64LE, 3, "mm");
  ds_.tool_position_mm = create_column(file_, "tool_position_mm", H5T_IEEE_F64LE, 3, "mm");
  ds_.force_n = create_column(file_, "force_n", H5T_IEEE_F64LE, 3, "N");
  ds_.force_scale = create_column(file_, "force_scale", H5T_IEEE_F64LE, 1, "1");
  ds_.displacement_mm = create_column(file_, "displacement_mm", H5T_IEEE_F64LE, 3, "mm");
  ds_.contact_area_mm2 = create_column(file_, "contact_area_mm2", H5T_IEEE_F64LE, 1, "mm^2");
  ds_.contact = create_column(file_, "contact", H5T_STD_U8LE, 1, nullptr);
  ds_.holding = create_column(file_, "holding", H5T_STD_U8LE, 1, nullptr);
  ds_.clamped = create_column(file_, "clamped", H5T_STD_U8LE, 1, nullptr);
  ds_.motion_fault = create_column(file_, "motion_fault", H5T_STD_U8LE, 1, nullptr);
  ds_.device_sequence = create_column(file_, "device_sequence", H5T_STD_I64LE, 1, nullptr);
  // Wall-clock measurements live under /timing: the only data that differ between runs.
  const hid_t timing = H5Gcreate2(file_, "timing", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ds_.compute_ns = create_column(timing, "compute_ns", H5T_STD_I64LE, 1, "ns");
  ds_.scheduled_ns = create_column(timing, "scheduled_ns", H5T_STD_I64LE, 1, "ns");
  ds_.start_ns = create_column(timing, "start_ns", H5T_STD_I64LE, 1, "ns");
  ds_.lateness_ns = create_column(timing, "lateness_ns", H5T_STD_I64LE, 1, "ns");
  ds_.watchdog = create_column(timing, "watchdog", H5T_STD_U8LE, 1, nullptr);
  H5Gclose(timing);
  const hid_t plastic = H5Gcreate2(file_, "plastic", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ds_.strain = create_column(plastic, "strain", H5T_IEEE_F64LE, 1, "1");
  ds_.stress_pa = create_column(plastic, "stress_pa", H5T_IEEE_F64LE, 1, "Pa");
  ds_.zone = create_column(plastic, "zone", H5T_STD_U8LE, 1, nullptr);
  ds_.plastic_event = create_column(plastic, "event", H5T_STD_U8LE, 1, nullptr);
  H5Gclose(plastic);
  const hid_t relax = H5Gcreate2(file_, "relax", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ds_.queue_depth = create_column(relax, "queue_depth", H5T_STD_I64LE, 1, nullptr);
  ds_.deleted_voxels = create_column(relax, "deleted_voxels", H5T_STD_I64LE, 1, nullptr);
  ds_.relaxed_voxels = create_column(relax, "relaxed_voxels", H5T_STD_I64LE, 1, nullptr);
  ds_.total_mass_units = create_column(relax, "total_mass_units", H5T_STD_I64LE, 1, nullptr);
  H5Gclose(relax);
  set_attribute("complete", std::int64_t{0});
  buffer_.reserve(flush_every_);
}

void SessionWriter::record_orientation() {
  HAPVOX_CHECK(buffer_.empty() && rows_written_ == 0);
  if (ds_.device_orientation >= 0) return;
  ds_.device_orientation =
      create_column(file_, "device_orientation", H5T_IEEE_F64LE, 4, "quaternion w,x,y,z");
}

SessionWriter::~SessionWriter() {
  if (file_ >= 0) {
    // Not closed: keep what was flushed in PATH.partial for post-mortems, never at PATH.
    flush_rows();
    close_datasets();
    H5Fclose(file_);
  }
}

void SessionWriter::close_datasets() {
  for (hid_t d : {ds_.time_s,           ds_.device_position_mm,
                  ds_.tool_position_mm, ds_.force_n,
                  ds_.force_scale,      ds_.displacement_mm,
                  ds_.contact_area_mm2, ds_.contact,
                  ds_.holding,          ds_.clamped,
                  ds_.motion_fault,     ds_.device_sequence,
                  ds_.compute_ns,       ds_.strain,
                  ds_.stress_pa,        ds_.zone,
                  ds_.plastic_event,    ds_.queue_depth,
                  ds_.deleted_voxels,   ds_.relaxed_voxels,
                  ds_.total_mass_units, ds_.scheduled_ns,
                  ds_.start_ns,         ds_.lateness_ns,
                  ds_.watchdog}) {
    H5Dclose(d);
  }
  if (ds_.device_orientation >= 0) H5Dclose(ds_.device_orientation);
}

void SessionWriter::set_attribute(const std::string& name, const std::string& value) {
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, value.size() + 1);
  H5Tset_cset(type, H5T_CSET_UTF8);
  const hid_t space = H5Screate(H5S_SCALAR);
  write_root_attribute(file_, name, type, space, value.c_str());
  H5Sclose(space);
  H5Tclose(type);
}

void SessionWriter::set_attribute(const std::string& name, double value) {
  const hid_t space = H5Screate(H5S_SCALAR);
  write_root_attribute(file_, name, H5T_NATIVE_DOUBLE, space, &value);
  H5Sclose(space);
}

void SessionWriter::set_attribute(const std::string& name, std::int64_t value) {
  const hid_t space = H5Screate(H5S_SCALAR);
  write_root_attribute(file_, name, H5T_NATIVE_INT64, space, &value);
  H5Sclose(space);
}

void SessionWriter::set_attribute(const std::string& name, const Vec3d& value) {
  const hsize_t dims[1] = {3};
  const hid_t space = H5Screate_simple(1, dims, nullptr);
  write_root_attribute(file_, name, H5T_NATIVE_DOUBLE, space, value.data());
  H5Sclose(space);
}

void SessionWriter::append(const TickRecord& row) {
  HAPVOX_CHECK(!closed_);
  buffer_.push_back(row);
  if (buffer_.size() >= flush_every_) flush_rows();
}

void SessionWriter::write_column(hid_t dataset, hid_t mem_type, const void* data,
                                 std::size_t columns) {
  const hsize_t n = buffer_.size();
  const int rank = columns == 1 ? 1 : 2;
  const hsize_t new_dims[2] = {rows_written_ + n, columns};
  HAPVOX_CHECK(H5Dset_extent(dataset, new_dims) >= 0);
  const hid_t file_space = H5Dget_space(dataset);
  const hsize_t start[2] = {rows_written_, 0};
  const hsize_t count[2] = {n, columns};
  H5Sselect_hyperslab(file_space, H5S_SELECT_SET, start, nullptr, count, nullptr);
  const hid_t mem_space = H5Screate_simple(rank, count, nullptr);
  HAPVOX_CHECK(H5Dwrite(dataset, mem_type, mem_space, file_space, H5P_DEFAULT, data) >= 0);
  H5Sclose(mem_space);
  H5Sclose(file_space);
}

void SessionWriter::flush_rows() {
  if (buffer_.empty()) return;
  const std::size_t n = buffer_.size();
  std::vector<double> scalars(n);
  std::vector<double> vectors(3 * n);
  std::vector<std::uint8_t> bytes(n);
  std::vector<std::int64_t> ints(n);
  auto scalar_column = [&](hid_t ds, auto field) {
    for (std::size_t i = 0; i < n; ++i) scalars[i] = field(buffer_[i]);
    write_column(ds, H5T_NATIVE_DOUBLE, scalars.data(), 1);
  };
  auto vector_column = [&](hid_t ds, auto field) {
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3d v = field(buffer_[i]);
      for (int a = 0; a < 3; ++a) vectors[3 * i + a] = v[a];
    }
    write_column(ds, H5T_NATIVE_DOUBLE, vectors.data(), 3);
  };
  auto byte_column = [&](hid_t ds, auto field) {
    for (std::size_t i = 0; i < n; ++i) bytes[i] = field(buffer_[i]);
    write_column(ds, H5T_NATIVE_UINT8, bytes.data(), 1);
  };
  scalar_column(ds_.time_s, [](const TickRecord& r) { return r.time_s; });
  vector_column(ds_.device_position_mm, [](const TickRecord& r) { return r.device_position_mm; });
  if (ds_.device_orientation >= 0) {
    std::vector<double> quaternions(4 * n);
    for (std::size_t i = 0; i < n; ++i) {
      for (int c = 0; c < 4; ++c) quaternions[4 * i + c] = buffer_[i].device_orientation_wxyz[c];
    }
    write_column(ds_.device_orientation, H5T_NATIVE_DOUBLE, quaternions.data(), 4);
  }
  vector_column(ds_.tool_position_mm, [](const TickRecord& r) { return r.tool_position_mm; });
  vector_column(ds_.force_n, [](const TickRecord& r) { return r.force_n; });
  scalar_column(ds_.force_scale, [](const TickRecord& r) { return r.force_scale; });
  vector_column(ds_.displacement_mm, [](const TickRecord& r) { return r.displacement_mm; });
  scalar_column(ds_.contact_area_mm2, [](const TickRecord& r) { return r.contact_area_mm2; });
  byte_column(ds_.contact, [](const TickRecord& r) { return r.contact; });
  byte_column(ds_.holding, [](const TickRecord& r) { return r.holding; });
  byte_column(ds_.clamped, [](const TickRecord& r) { return r.clamped; });
  byte_column(ds_.motion_fault, [](const TickRecord& r) { return r.motion_fault; });
  auto int_column = [&](hid_t ds, auto field) {
    for (std::size_t i = 0; i < n; ++i) ints[i] = field(buffer_[i]);
    write_column(ds, H5T_NATIVE_INT64, ints.data(), 1);
  };
  int_column(ds_.device_sequence, [](const TickRecord& r) { return r.device_sequence; });
  int_column(ds_.compute_ns, [](const TickRecord& r) { return r.compute_ns; });
  int_column(ds_.scheduled_ns, [](const TickRecord& r) { return r.scheduled_ns; });
  int_column(ds_.start_ns, [](const TickRecord& r) { return r.start_ns; });
  int_column(ds_.lateness_ns, [](const TickRecord& r) { return r.start_ns - r.scheduled_ns; });
  byte_column(ds_.watchdog, [](const TickRecord& r) { return r.watchdog; });
  scalar_column(ds_.strain, [](const TickRecord& r) { return r.strain; });
  scalar_column(ds_.stress_pa, [](const TickRecord& r) { return r.stress_measure_pa; });
  byte_column(ds_.zone, [](const TickRecord& r) { return r.zone; });
  byte_column(ds_.plastic_event, [](const TickRecord& r) { return r.plastic_event; });
  int_column(ds_.queue_depth, [](const TickRecord& r) { return r.queue_depth; });
  int_column(ds_.deleted_voxels, [](const TickRecord& r) { return r.deleted_voxels; });
  int_column(ds_.relaxed_voxels, [](const TickRecord& r) { return r.relaxed_voxels; });
  int_column(ds_.total_mass_units, [](const TickRecord& r) { return r.total_mass_units; });
  rows_written_ += n;
  buffer_.clear();
  H5Fflush(file_, H5F_SCOPE_LOCAL);
}

void SessionWriter::write_array(const std::string& path, const std::vector<std::int64_t>& values,
                                const char* unit) {
  HAPVOX_CHECK(!closed_);
  const hid_t dataset = create_column(file_, path.c_str(), H5T_STD_I64LE, 1, unit);
  const hsize_t n = values.size();
  if (n > 0) {
    HAPVOX_CHECK(H5Dset_extent(dataset, &n) >= 0);
    HAPVOX_CHECK(
        H5Dwrite(dataset, H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) >= 0);
  }
  H5Dclose(dataset);
}

void SessionWriter::write_array(const std::string& path, const std::vector<double>& values,
                                const std::vector<std::size_t>& dims, const char* unit) {
  HAPVOX_CHECK(!closed_);
  std::vector<hsize_t> extent(dims.begin(), dims.end());
  std::size_t count = 1;
  for (const std::size_t d : dims) count *= d;
  HAPVOX_CHECK_EQ(values.size(), count);
  const hid_t space = H5Screate_simple(static_cast<int>(extent.size()), extent.data(), nullptr);
  const hid_t link_props = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(link_props, 1);
  const hid_t dataset =
      H5Dcreate2(file_, path.c_str(), H5T_IEEE_F64LE, space, link_props, H5P_DEFAULT, H5P_DEFAULT);
  H5Pclose(link_props);
  H5Sclose(space);
  HAPVOX_CHECK(dataset >= 0);
  if (count > 0) {
    HAPVOX_CHECK(
        H5Dwrite(dataset, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) >= 0);
  }
  if (unit != nullptr) set_string_attribute(dataset, "units", unit);
  H5Dclose(dataset);
}

void SessionWriter::close() {
  HAPVOX_CHECK(!closed_);
  flush_rows();
  set_attribute("rows", static_cast<std::int64_t>(rows_written_));
  set_attribute("complete", std::int64_t{1});
  close_datasets();
  const herr_t status = H5Fclose(file_);
  file_ = -1;
  closed_ = true;
  if (status < 0) throw InputError(path_, "failed to finish writing the session file");
  output_->commit();
}

void SessionWriter::abandon() {
  if (file_ >= 0) {
    close_datasets();
    H5Fclose(file_);
    file_ = -1;
  }
  closed_ = true;
  output_->discard();
}

std::vector<std::pair<std::string, std::string>> library_versions() {
  unsigned major = 0, minor = 0, release = 0;
  H5get_libversion(&major, &minor, &release);
  std::ostringstream hdf5;
  hdf5 << major << "." << minor << "." << release;
  std::ostringstream eigen;
  eigen << EIGEN_WORLD_VERSION << "." << EIGEN_MAJOR_VERSION << "." << EIGEN_MINOR_VERSION;
  return {{"hapvox", kVersion},
          {"openvdb", OPENVDB_LIBRARY_VERSION_STRING},
          {"hdf5", hdf5.str()},
          {"eigen", eigen.str()}};
}

}  // namespace hapvox::haptics

namespace hapvox::haptics {
namespace {

struct Handle {
  hid_t id;
  herr_t (*close)(hid_t);
  ~Handle() {
    if (id >= 0) close(id);
  }
};

std::string attribute_text(hid_t attr) {
  const Handle type{H5Aget_type(attr), H5Tclose};
  const Handle space{H5Aget_space(attr), H5Sclose};
  const hssize_t count = H5Sget_simple_extent_npoints(space.id);
  const H5T_class_t cls = H5Tget_class(type.id);
  std::ostringstream out;
  if (cls == H5T_STRING && !H5Tis_variable_str(type.id)) {
    std::string text(H5Tget_size(type.id), '\0');
    H5Aread(attr, type.id, text.data());
    out << text.c_str();
  } else if (cls == H5T_INTEGER && H5Tget_sign(type.id) == H5T_SGN_NONE) {
    // Integers exactly: a mass of 28991029248 units, not 2.8991e+10, which would hide a
    // drift of thousands.
    std::vector<unsigned long long> values(static_cast<std::size_t>(std::max<hssize_t>(count, 1)));
    H5Aread(attr, H5T_NATIVE_ULLONG, values.data());
    for (std::size_t i = 0; i < values.size(); ++i) out << (i ? " " : "") << values[i];
  } else if (cls == H5T_INTEGER) {
    std::vector<long long> values(static_cast<std::size_t>(std::max<hssize_t>(count, 1)));
    H5Aread(attr, H5T_NATIVE_LLONG, values.data());
    for (std::size_t i = 0; i < values.size(); ++i) out << (i ? " " : "") << values[i];
  } else if (cls == H5T_FLOAT) {
    std::vector<double> values(static_cast<std::size_t>(std::max<hssize_t>(count, 1)));
    H5Aread(attr, H5T_NATIVE_DOUBLE, values.data());
    for (std::size_t i = 0; i < values.size(); ++i) out << (i ? " " : "") << values[i];
  } else {
    out << "(unsupported type)";
  }
  return out.str();
}

herr_t collect_attribute(hid_t location, const char* name, const H5A_info_t*, void* data) {
  auto* info = static_cast<SessionInfo*>(data);
  const Handle attr{H5Aopen(location, name, H5P_DEFAULT), H5Aclose};
  info->attributes.emplace_back(name, attribute_text(attr.id));
  return 0;
}

herr_t collect_dataset(hid_t, const char* name, const H5O_info_t* object, void* data) {
  if (object->type == H5O_TYPE_DATASET) {
    static_cast<SessionInfo*>(data)->datasets.push_back(std::string("/") + name);
  }
  return 0;
}

}  // namespace

bool is_hdf5_file(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  return H5Fis_hdf5(path.c_str()) > 0;
}

hid_t open_session_for_reading(const std::string& path, bool read_write) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t access = H5Pcreate(H5P_FILE_ACCESS);
  // A session left by a killed run still says "open for write" in its superblock: HDF5's
  // own (h5clear's) property reads it anyway; read-only, nothing on disk changes.
  hbool_t clear = true;
  H5Pset(access, "clear_status_flags", &clear);
  // A run writing it holds its lock (engine/io/output_file.h); reading is still allowed.
  H5Pset_file_locking(access, false, true);
  const hid_t file = H5Fopen(path.c_str(), read_write ? H5F_ACC_RDWR : H5F_ACC_RDONLY, access);
  H5Pclose(access);
  return file;
}

SessionInfo read_session_info(const std::string& path) {
  if (!std::filesystem::exists(path)) throw InputError(path, "cannot open file");
  if (!is_hdf5_file(path)) throw InputError(path, "not an HDF5 file");
  const Handle file{open_session_for_reading(path), H5Fclose};
  if (file.id < 0) throw InputError(path, "cannot open HDF5 file");
  SessionInfo info;
  hsize_t index = 0;
  H5Aiterate2(file.id, H5_INDEX_NAME, H5_ITER_INC, &index, collect_attribute, &info);
  H5Ovisit(file.id, H5_INDEX_NAME, H5_ITER_INC, collect_dataset, &info);
  for (const auto& [name, value] : info.attributes) {
    if (name == "complete") info.complete = value == "1";
  }
  if (H5Lexists(file.id, "time_s", H5P_DEFAULT) <= 0) {
    throw InputError(path, "not a hapvox session (no /time_s dataset)");
  }
  const Handle ds{H5Dopen2(file.id, "time_s", H5P_DEFAULT), H5Dclose};
  const Handle space{H5Dget_space(ds.id), H5Sclose};
  info.rows = static_cast<std::size_t>(H5Sget_simple_extent_npoints(space.id));
  return info;
}

std::vector<double> read_session_column(const std::string& path, const std::string& dataset,
                                        std::vector<std::size_t>* dims) {
  if (!is_hdf5_file(path)) throw InputError(path, "not an HDF5 file");
  const Handle file{open_session_for_reading(path), H5Fclose};
  if (file.id < 0) throw InputError(path, "cannot open HDF5 file");
  const Handle ds{H5Dopen2(file.id, dataset.c_str(), H5P_DEFAULT), H5Dclose};
  if (ds.id < 0) throw InputError(path, "no dataset " + dataset);
  const Handle type{H5Dget_type(ds.id), H5Tclose};
  const H5T_class_t type_class = H5Tget_class(type.id);
  if (type_class != H5T_INTEGER && type_class != H5T_FLOAT) {
    throw InputError(path, "dataset " + dataset + " is not numeric");
  }
  const Handle space{H5Dget_space(ds.id), H5Sclose};
  if (dims != nullptr) {
    const int rank = H5Sget_simple_extent_ndims(space.id);
    std::vector<hsize_t> extent(static_cast<std::size_t>(std::max(rank, 0)));
    if (rank > 0) H5Sget_simple_extent_dims(space.id, extent.data(), nullptr);
    dims->assign(extent.begin(), extent.end());
  }
  std::vector<double> values(static_cast<std::size_t>(H5Sget_simple_extent_npoints(space.id)));
  if (!values.empty() &&
      H5Dread(ds.id, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0) {
    throw InputError(path, "cannot read dataset " + dataset);
  }
  return values;
}

}  // namespace hapvox::haptics
