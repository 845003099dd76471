#pragma once
// NIfTI-1 and NIfTI-2 volumes (.nii, .nii.gz; .hdr/.img pairs), the format of brain MRI
// and of 3D Slicer's label maps. The header goes through Debian's nifticlib
// (libnifti2-dev: its sform/qform arithmetic); the payload through hapvox's own bounded
// readers (engine/io/payload.h), so a header claiming a huge image allocates nothing.
// NIfTI's world is RAS; it is turned into hapvox's LPS here, at the edge.

#include <string>

#include "engine/density_field.h"
#include "engine/io/raw_volume.h"
#include "engine/io/written_volume.h"

namespace hapvox::engine::io {

/// Reads a 3-D scalar NIfTI volume. Orientation from the sform when its code is set, else
/// the qform, else the voxel sizes alone; samples scaled by scl_slope and scl_inter when
/// the slope is non-zero; spacing in millimetres whatever xyzt_units says. Throws
/// InputError(PATH, ...) on a missing file, a bad header, more than 3 dimensions, an
/// unsupported datatype, a sheared sform, short or corrupt data, non-finite samples.
RawVolume read_nifti(const std::string& path);

/// The image file an .hdr names (NAME.img), or "" when the data is in the .nii itself.
std::string nifti_data_file(const std::string& path);

/// Writes a density field as a single-file NIfTI-1 (.nii, or gzip-compressed .nii.gz):
/// float samples, sform and qform (scanner anatomical) holding spacing, direction and
/// origin, intent name "hapvox_density". Written to PATH.partial then renamed.
void write_nifti(const DensityField& field, const std::string& path);

/// Writes a volume the same way in its sample type; a label map gets intent code
/// NIFTI_INTENT_LABEL and intent name "hapvox_labels".
void write_nifti_volume(const WrittenVolume& volume, const std::string& path);

}  // namespace hapvox::engine::io
