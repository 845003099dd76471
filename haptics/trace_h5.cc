// HDF5 traces (haptics/trace.h): 1-D datasets at the file's root, one per column.
#include "haptics/trace.h"

#include <hdf5.h>

#include <array>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "engine/errors.h"
#include "engine/input_limits.h"
#include "haptics/hdf5_id.h"
#include "haptics/trace_raw.h"

namespace hapvox::haptics {
namespace {

// HDF5 prints its error stack to stderr by default; our messages say it better.
void silence_hdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

std::vector<double> read_h5_column(const std::string& path, hid_t file, const std::string& name) {
  const htri_t exists = H5Lexists(file, name.c_str(), H5P_DEFAULT);
  if (exists <= 0) throw InputError(path, "missing dataset '" + name + "'");
  H5Id dataset(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!dataset.valid()) throw InputError(path, "'" + name + "' is not a dataset");
  H5Id type(H5Dget_type(dataset.get()), H5Tclose);
  const H5T_class_t type_class = type.valid() ? H5Tget_class(type.get()) : H5T_NO_CLASS;
  if (type_class != H5T_INTEGER && type_class != H5T_FLOAT) {
    throw InputError(path, "dataset '" + name + "' is not numeric");
  }
  H5Id space(H5Dget_space(dataset.get()), H5Sclose);
  const int rank = space.valid() ? H5Sget_simple_extent_ndims(space.get()) : -1;
  if (rank != 1) {
    throw InputError(path, "dataset '" + name + "' is not 1-D (rank " + std::to_string(rank) + ")");
  }
  hsize_t length = 0;
  H5Sget_simple_extent_dims(space.get(), &length, nullptr);
  // The dataspace is a header's word: a 2 kB file may declare 2^40 rows.
  engine::check_trace_rows(static_cast<double>(length), path,
                           "dataset '" + printable(name, 40) + "' declares");
  std::vector<double> values(static_cast<std::size_t>(length));
  if (length > 0 &&
      H5Dread(dataset.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0) {
    throw InputError(path, "cannot read dataset '" + name + "' as float64");
  }
  return values;
}

void write_h5_column(const std::string& path, hid_t file, const char* name,
                     const std::vector<double>& values) {
  const hsize_t length = values.size();
  H5Id space(H5Screate_simple(1, &length, nullptr), H5Sclose);
  H5Id dataset(
      H5Dcreate2(file, name, H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
      H5Dclose);
  if (!space.valid() || !dataset.valid() ||
      (length > 0 && H5Dwrite(dataset.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT,
                              values.data()) < 0)) {
    throw InputError(path, std::string("cannot write dataset '") + name + "'");
  }
}

}  // namespace

using detail::check_scales;
using detail::check_trace_shape;
using detail::finish_trace;
using detail::RawTrace;

Trace read_h5_trace(const std::string& path, const TraceColumns& columns) {
  check_scales(path, columns);
  silence_hdf5();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw InputError(path, "cannot open file");
  if (H5Fis_hdf5(path.c_str()) <= 0) throw InputError(path, "not an HDF5 file");
  H5Id file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.valid()) throw InputError(path, "cannot open HDF5 file");

  RawTrace raw;
  raw.kind = "dataset";
  raw.time = read_h5_column(path, file.get(), columns.time);
  std::array<std::vector<double>, 3> position;
  for (int a = 0; a < 3; ++a) {
    position[a] = read_h5_column(path, file.get(), columns.position[a]);
    if (position[a].size() != raw.time.size()) {
      throw InputError(path, "dataset '" + columns.position[a] + "' has " +
                                 std::to_string(position[a].size()) + " values but dataset '" +
                                 columns.time + "' has " + std::to_string(raw.time.size()));
    }
  }
  raw.position.resize(raw.time.size());
  for (std::size_t i = 0; i < raw.time.size(); ++i) {
    raw.position[i] = {position[0][i], position[1][i], position[2][i]};
  }
  if (columns.has_orientation()) {
    std::array<std::vector<double>, 4> q;
    for (int c = 0; c < 4; ++c) {
      q[c] = read_h5_column(path, file.get(), columns.orientation[c]);
      if (q[c].size() != raw.time.size()) {
        throw InputError(path, "dataset '" + columns.orientation[c] + "' has " +
                                   std::to_string(q[c].size()) + " values but dataset '" +
                                   columns.time + "' has " + std::to_string(raw.time.size()));
      }
    }
    for (std::size_t i = 0; i < raw.time.size(); ++i) {
      raw.orientation.push_back({q[0][i], q[1][i], q[2][i], q[3][i]});
    }
  }
  raw.where = [](std::size_t i) { return "index " + std::to_string(i); };
  return finish_trace(path, columns, raw);
}

void write_h5_trace(const Trace& trace, const std::string& path) {
  check_trace_shape(trace, path);
  silence_hdf5();
  // Through PATH.partial, renamed once complete (engine/io/output_file.h).
  engine::io::OutputFile out(path);
  try {
    H5Id file(create_hdf5_output(out), H5Fclose);
    std::array<std::vector<double>, 3> position;
    for (const Vec3d& p : trace.position_mm) {
      for (int a = 0; a < 3; ++a) position[a].push_back(p[a]);
    }
    write_h5_column(path, file.get(), "t", trace.time_s);
    write_h5_column(path, file.get(), "x", position[0]);
    write_h5_column(path, file.get(), "y", position[1]);
    write_h5_column(path, file.get(), "z", position[2]);
    if (!file.close()) throw InputError(path, "cannot finish writing " + out.partial_path());
    out.commit();
  } catch (...) {
    out.discard();
    throw;
  }
}

}  // namespace hapvox::haptics
