#pragma once
// An HDF5 trace that declares more rows than it holds: datasets t, x, y, z of `rows` rows
// each, chunked and never written (HDF5 stores chunks only once written), in a file of a
// few kB. For the tests of --max-trace-rows (haptics/trace_h5.cc, tools/input_limits.cc).

#include <hdf5.h>

#include <string>

namespace hapvox::testing {

/// Writes the file; false when HDF5 refuses.
inline bool write_h5_declaring_rows(const std::string& path, hsize_t rows) {
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  const hid_t space = H5Screate_simple(1, &rows, nullptr);
  const hid_t layout = H5Pcreate(H5P_DATASET_CREATE);
  const hsize_t chunk_rows = rows < 4096 ? rows : 4096;  // no larger than the dataset
  bool ok = file >= 0 && space >= 0 && layout >= 0 && H5Pset_chunk(layout, 1, &chunk_rows) >= 0;
  for (const char* name : {"t", "x", "y", "z"}) {
    const hid_t set =
        ok ? H5Dcreate2(file, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, layout, H5P_DEFAULT) : -1;
    ok = set >= 0;
    if (ok) H5Dclose(set);
  }
  if (layout >= 0) H5Pclose(layout);
  if (space >= 0) H5Sclose(space);
  if (file >= 0) H5Fclose(file);
  return ok;
}

}  // namespace hapvox::testing
