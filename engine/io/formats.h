#pragma once
// The table of volume formats and generators. Every place that names formats (load_volume,
// the label reader, `hapvox info`, help texts, error messages, the no-overwrite check's
// companion files) asks this table, so a new format is a new file plus one row here.
// Extensions match case-insensitively.

#include <string>
#include <vector>

#include "engine/density_field.h"
#include "engine/io/generators.h"
#include "engine/io/intensity.h"
#include "engine/io/raw_volume.h"
#include "engine/io/written_volume.h"

namespace hapvox::engine::io {

struct VolumeFormat {
  const char* name;                     // "NRRD"
  std::vector<std::string> extensions;  // lower case, with the dot: ".nrrd", ".nhdr"
  /// True when the format stores scanner samples (mapped to density on load, unless the
  /// file says hapvox wrote densities), false when it stores a density grid.
  bool holds_samples = true;
  /// True when a folder is read as one volume (a DICOM series).
  bool reads_folders = false;
  /// True when the file name may be followed by ':' and options (a raw file's layout:
  /// "scan.raw:dims=...").
  bool takes_options = false;
  /// The samples as stored (intensities, labels or densities), dense.
  RawVolume (*read_samples)(const std::string& path) = nullptr;
  /// A density field: scanner samples through the intensity mapping, densities as they are.
  DensityField (*load)(const std::string& path, const IntensityMapping& mapping) = nullptr;
  /// Writes a density field (nullptr: hapvox does not write the format).
  void (*write)(const DensityField& field, const std::string& path) = nullptr;
  /// Writes a label map as integers (engine/io/written_volume.h); set where `write` is.
  void (*write_labels)(const WrittenVolume& labels, const std::string& path) = nullptr;
  /// The extensions `write` writes, when fewer than it reads (NIfTI: one file, not .hdr);
  /// empty: all of `extensions`.
  std::vector<std::string> written_extensions = {};
  /// The other file this file names and reads (a detached header's data), "" for none.
  std::string (*data_file)(const std::string& path) = nullptr;
  /// The data file `write` writes beside PATH (a .mhd's NAME.zraw), "" for none.
  std::string (*written_data_file)(const std::string& path) = nullptr;
};

/// Every format, in the order help texts list them.
const std::vector<VolumeFormat>& volume_formats();

/// The format whose extension `path` ends with (any case), the folder-reading format for an
/// existing folder, or nullptr.
const VolumeFormat* find_volume_format(const std::string& path);

/// The format hapvox writes to `path` by its extension (any case), or nullptr when it
/// writes none there (an unknown extension, a read-only format, NIfTI's .hdr).
const VolumeFormat* find_written_format(const std::string& path);
/// The same, or InputError(path, "unknown output format (expected .nrrd, ...)").
const VolumeFormat& written_format(const std::string& path);

/// format.data_file(path) and format.written_data_file(path); "" when the format has none.
std::string companion_input(const VolumeFormat& format, const std::string& path);
std::string companion_output(const VolumeFormat& format, const std::string& path);

/// The extensions joined by `separator`, the last by `last` (".nrrd, .nhdr or .vdb"); of
/// the formats hapvox writes only, when `written`.
std::string volume_extensions_text(const std::string& separator, const std::string& last,
                                   bool written = false);

/// The generator names joined by ", " ("block, sphere, four-spheres").
std::string generator_names_text();

/// Loads a file by its format, or runs a generator. Throws InputError(spec, "unknown volume
/// format (...)") naming every extension and generator when neither matches.
DensityField load_volume(const std::string& spec, const IntensityMapping& mapping);

/// The dense samples of a file (as stored) or of a generator's densities.
RawVolume read_scalar_volume(const std::string& spec);

/// Writes a label map (integer samples, e.g. read_scalar_volume of a label file) to `path`
/// in the format its extension names, as integers (written_volume.h). Throws
/// InputError(path, "unknown output format (expected ...)") for an extension hapvox does not
/// write, InputError(source, ...) for a sample that is not a label.
void write_label_volume(const RawVolume& labels, const std::string& source,
                        const std::string& path);

}  // namespace hapvox::engine::io
