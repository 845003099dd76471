#pragma once
// An owned HDF5 identifier, for the readers and writers of HDF5 files in haptics/.

#include <hdf5.h>

#include "engine/errors.h"
#include "engine/io/output_file.h"

namespace hapvox::haptics {

// Owns one HDF5 identifier; closes it with the matching H5?close.
class H5Id {
 public:
  H5Id(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  H5Id(const H5Id&) = delete;
  H5Id& operator=(const H5Id&) = delete;
  ~H5Id() {
    if (id_ >= 0) close_(id_);
  }
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  // Closes now and reports failure (a file's close is where buffered writes land).
  bool close() {
    const herr_t status = id_ >= 0 ? close_(id_) : -1;
    id_ = -1;
    return status >= 0;
  }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

/// Creates the HDF5 file of `out`, in the partial file `out` created and locks, with the
/// settings of the file access list `access` (or the defaults). HDF5's own file lock is
/// off: `out`'s lock keeps other runs away, and two flocks on one file, even in one process,
/// exclude each other. Throws InputError(out.path(), ...) if it cannot.
inline hid_t create_hdf5_output(const engine::io::OutputFile& out, hid_t access = H5P_DEFAULT) {
  const hid_t list = access == H5P_DEFAULT ? H5Pcreate(H5P_FILE_ACCESS) : H5Pcopy(access);
  H5Pset_file_locking(list, false, true);
  const hid_t file = H5Fcreate(out.partial_path().c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, list);
  H5Pclose(list);
  if (file < 0) throw InputError(out.path(), "cannot create " + out.partial_path());
  try {
    out.verify();
  } catch (...) {
    H5Fclose(file);
    throw;
  }
  return file;
}

}  // namespace hapvox::haptics
