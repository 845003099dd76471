#pragma once
// DICOM series: a folder of single-frame slices (CT, MR), or one .dcm file, read through
// GDCM (libgdcm-dev: the parsing and every transfer syntax's decompression). DICOM's
// patient frame is LPS, hapvox's own: positions and directions pass through unchanged.

#include <string>

#include "engine/io/raw_volume.h"

namespace hapvox::engine::io {

/// Reads the slices of a folder (files that are not DICOM are skipped; every DICOM file must
/// belong to one series) or a single .dcm file. Slices are sorted by their position along
/// the normal of their common orientation (ImagePositionPatient . (row x column)), whatever
/// the file names and instance numbers say. Samples become Rescale Slope * v + Rescale
/// Intercept: Hounsfield units for CT. The direction's columns are the row direction, the
/// column direction and the normal; the origin is the first slice's ImagePositionPatient;
/// the slice spacing comes from the positions (SliceThickness for a single slice).
///
/// Throws InputError(PATH, ...) on: no DICOM file, several series, slices of different
/// sizes or orientations, two slices at one position, gantry tilt (the slices step off their
/// normal), non-uniform slice spacing (more than 1 % apart), colour or multi-frame images,
/// more than 2^31 samples (before allocating), pixel data GDCM cannot decode, a file that ends
/// inside its pixel data (GDCM would read the rest as zeros).
///
/// GDCM runs in a child process (engine/io/child_read.h): Debian's build keeps its assertions,
/// and a truncated or corrupt file trips them; then the child dies, not hapvox, and this
/// throws InputError(PATH, "GDCM crashed reading it (signal 6, Aborted): ...").
RawVolume read_dicom(const std::string& path);

}  // namespace hapvox::engine::io
