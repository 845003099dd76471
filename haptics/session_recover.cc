#include "haptics/session_recover.h"

#include <fcntl.h>
#include <hdf5.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <limits>
#include <vector>

#include "engine/errors.h"
#include "engine/io/output_file.h"
#include "haptics/hdf5_id.h"
#include "haptics/session.h"

namespace hapvox::haptics {

namespace {

// Copies the bytes of `path` into `out`.
void copy_file_into(const std::string& path, engine::io::OutputFile& out) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw InputError(path, "cannot open file");
  std::vector<char> buffer(1 << 20);
  for (;;) {
    const ssize_t n = ::read(fd, buffer.data(), buffer.size());
    if (n == 0) break;
    if (n < 0) {
      ::close(fd);
      throw InputError(path, "cannot read file");
    }
    out.write(buffer.data(), static_cast<std::size_t>(n));
  }
  ::close(fd);
}

// The per-tick columns: every dataset that grows along its first axis.
herr_t collect_row_column(hid_t root, const char* name, const H5O_info_t* object, void* data) {
  if (object->type != H5O_TYPE_DATASET) return 0;
  H5Id set(H5Dopen2(root, name, H5P_DEFAULT), H5Dclose);
  H5Id space(H5Dget_space(set.get()), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 1 || rank > 4) return 0;
  hsize_t dims[4], max_dims[4];
  H5Sget_simple_extent_dims(space.get(), dims, max_dims);
  if (max_dims[0] == H5S_UNLIMITED) static_cast<std::vector<std::string>*>(data)->push_back(name);
  return 0;
}

void set_int_attribute(hid_t file, const char* name, std::int64_t value) {
  if (H5Aexists(file, name) > 0) H5Adelete(file, name);
  H5Id space(H5Screate(H5S_SCALAR), H5Sclose);
  H5Id attribute(H5Acreate2(file, name, H5T_STD_I64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT),
                 H5Aclose);
  H5Awrite(attribute.get(), H5T_NATIVE_INT64, &value);
}

// Cuts every per-tick column of `file` to the rows all of them hold; returns that count.
std::size_t cut_columns_to_common_rows(hid_t file, const std::string& source) {
  std::vector<std::string> columns;
  H5Ovisit(file, H5_INDEX_NAME, H5_ITER_INC, collect_row_column, &columns);
  if (std::find(columns.begin(), columns.end(), "time_s") == columns.end()) {
    throw InputError(source, "not a hapvox session (no per-tick /time_s dataset)");
  }
  hsize_t rows = std::numeric_limits<hsize_t>::max();
  for (const std::string& name : columns) {
    H5Id set(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
    H5Id space(H5Dget_space(set.get()), H5Sclose);
    hsize_t dims[4];
    H5Sget_simple_extent_dims(space.get(), dims, nullptr);
    rows = std::min(rows, dims[0]);
  }
  for (const std::string& name : columns) {
    H5Id set(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
    H5Id space(H5Dget_space(set.get()), H5Sclose);
    hsize_t dims[4];
    H5Sget_simple_extent_dims(space.get(), dims, nullptr);
    if (dims[0] == rows) continue;
    dims[0] = rows;
    if (H5Dset_extent(set.get(), dims) < 0) {
      throw InputError(source,
                       "cannot cut dataset /" + name + " to " + std::to_string(rows) + " rows");
    }
  }
  return static_cast<std::size_t>(rows);
}

}  // namespace

RecoveredSession recover_session(const std::string& partial_path, const std::string& output_path) {
  struct stat st {};
  if (::stat(partial_path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) {
    throw InputError(partial_path, "cannot open file");
  }
  if (!is_hdf5_file(partial_path)) throw InputError(partial_path, "not an HDF5 file");
  if (::lstat(output_path.c_str(), &st) == 0) {
    throw InputError(output_path, "exists: recover into another name (-o), nothing is replaced");
  }
  engine::io::OutputFile out(output_path, ".recovering");
  RecoveredSession recovered;
  try {
    copy_file_into(partial_path, out);
    H5Id file(open_session_for_reading(out.partial_path(), true), H5Fclose);
    if (!file.valid()) throw InputError(partial_path, "cannot open HDF5 file");
    recovered.rows = cut_columns_to_common_rows(file.get(), partial_path);
    set_int_attribute(file.get(), "rows", static_cast<std::int64_t>(recovered.rows));
    set_int_attribute(file.get(), "complete", 1);
    set_int_attribute(file.get(), "recovered", 1);
    if (!file.close()) throw InputError(output_path, "failed to finish writing the session file");
    out.commit();
  } catch (...) {
    out.discard();
    throw;
  }
  if (recovered.rows > 0) {
    const std::vector<double> time_s = read_session_column(output_path, "/time_s");
    recovered.first_time_s = time_s.front();
    recovered.last_time_s = time_s.back();
  }
  return recovered;
}

}  // namespace hapvox::haptics
