#pragma once
// An owned HDF5 identifier, for the readers and writers of HDF5 files in haptics/.

#include <hdf5.h>

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

}  // namespace hapvox::haptics
