#include "engine/io/formats.h"

#include <cstddef>
#include <filesystem>
#include <system_error>

#include "engine/errors.h"
#include "engine/io/dicom.h"
#include "engine/io/metaimage.h"
#include "engine/io/nifti.h"
#include "engine/io/nrrd.h"
#include "engine/io/raw_file.h"
#include "engine/io/text.h"
#include "engine/io/vdb.h"

namespace hapvox::engine::io {
namespace {

DensityField load_nrrd(const std::string& path, const IntensityMapping& mapping) {
  return load_samples(read_nrrd(path), mapping, path);
}

DensityField load_metaimage(const std::string& path, const IntensityMapping& mapping) {
  return load_samples(read_metaimage(path), mapping, path);
}

DensityField load_nifti(const std::string& path, const IntensityMapping& mapping) {
  return load_samples(read_nifti(path), mapping, path);
}

DensityField load_dicom(const std::string& path, const IntensityMapping& mapping) {
  return load_samples(read_dicom(path), mapping, path);
}

DensityField load_raw_file(const std::string& spec, const IntensityMapping& mapping) {
  return load_samples(read_raw_file(spec), mapping, spec);
}

DensityField load_vdb(const std::string& path, const IntensityMapping&) { return read_vdb(path); }

std::string unknown_format_message() {
  return "unknown volume format (expected " + volume_extensions_text(", ", " or ") +
         ", a folder of DICOM slices, or a generator: " + generator_names_text() + ")";
}

}  // namespace

const std::vector<VolumeFormat>& volume_formats() {
  static const std::vector<VolumeFormat> formats = {
      {.name = "NRRD",
       .extensions = {".nrrd", ".nhdr"},
       .read_samples = read_nrrd,
       .load = load_nrrd,
       .write = write_nrrd,
       .write_labels = write_nrrd_volume,
       .data_file = nrrd_data_file},
      {.name = "OpenVDB",
       .extensions = {".vdb"},
       .holds_samples = false,
       .read_samples = read_vdb_samples,
       .load = load_vdb,
       .write = write_vdb,
       .write_labels = write_vdb_labels},
      {.name = "MetaImage",
       .extensions = {".mha", ".mhd"},
       .read_samples = read_metaimage,
       .load = load_metaimage,
       .write = write_metaimage,
       .write_labels = write_metaimage_volume,
       .data_file = metaimage_data_file,
       .written_data_file = metaimage_written_data_file},
      {.name = "NIfTI",
       .extensions = {".nii", ".nii.gz", ".hdr"},
       .read_samples = read_nifti,
       .load = load_nifti,
       .write = write_nifti,
       .write_labels = write_nifti_volume,
       .written_extensions = {".nii", ".nii.gz"},
       .data_file = nifti_data_file},
      {.name = "DICOM",
       .extensions = {".dcm"},
       .reads_folders = true,
       .read_samples = read_dicom,
       .load = load_dicom},
      {.name = "raw",
       .extensions = {".raw"},
       .takes_options = true,
       .read_samples = read_raw_file,
       .load = load_raw_file,
       .data_file = raw_data_file},
  };
  return formats;
}

const VolumeFormat* find_volume_format(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    for (const VolumeFormat& format : volume_formats()) {
      if (format.reads_folders) return &format;
    }
    return nullptr;
  }
  const std::string name = lower(path);
  for (const VolumeFormat& format : volume_formats()) {
    for (const std::string& ext : format.extensions) {
      if (format.takes_options) {  // "name.raw:options"
        const std::size_t at = name.find(ext + ":");
        if (at != std::string::npos && at > 0 && name[at - 1] != '/') return &format;
      }
      // The extension must follow a file name, not be one: "dir/.nrrd" is no NRRD.
      if (ends_with(name, ext) && name.size() > ext.size() &&
          name[name.size() - ext.size() - 1] != '/') {
        return &format;
      }
    }
  }
  return nullptr;
}

const VolumeFormat* find_written_format(const std::string& path) {
  const VolumeFormat* format = find_volume_format(path);
  if (format == nullptr || format->write == nullptr) return nullptr;
  if (format->written_extensions.empty()) return format;
  const std::string name = lower(path);
  for (const std::string& ext : format->written_extensions) {
    if (ends_with(name, ext)) return format;
  }
  return nullptr;
}

const VolumeFormat& written_format(const std::string& path) {
  const VolumeFormat* format = find_written_format(path);
  if (format == nullptr) {
    throw InputError(path, "unknown output format (expected " +
                               volume_extensions_text(", ", " or ", true) + ")");
  }
  return *format;
}

std::string companion_input(const VolumeFormat& format, const std::string& path) {
  return format.data_file == nullptr ? "" : format.data_file(path);
}

std::string companion_output(const VolumeFormat& format, const std::string& path) {
  return format.written_data_file == nullptr ? "" : format.written_data_file(path);
}

std::string volume_extensions_text(const std::string& separator, const std::string& last,
                                   bool written) {
  std::vector<std::string> all;
  for (const VolumeFormat& format : volume_formats()) {
    if (written && format.write == nullptr) continue;
    const std::vector<std::string>& listed = written && !format.written_extensions.empty()
                                                 ? format.written_extensions
                                                 : format.extensions;
    all.insert(all.end(), listed.begin(), listed.end());
  }
  std::string text;
  for (std::size_t i = 0; i < all.size(); ++i) {
    text += (i == 0 ? "" : i + 1 == all.size() ? last : separator) + all[i];
  }
  return text;
}

std::string generator_names_text() {
  std::string text;
  for (const VolumeGenerator& g : volume_generators()) {
    text += (text.empty() ? "" : ", ") + std::string(g.name);
  }
  return text;
}

DensityField load_volume(const std::string& spec, const IntensityMapping& mapping) {
  if (is_generator_spec(spec)) return generate_volume(spec);
  if (const VolumeFormat* format = find_volume_format(spec)) return format->load(spec, mapping);
  throw InputError(spec, unknown_format_message());
}

RawVolume read_scalar_volume(const std::string& spec) {
  if (is_generator_spec(spec)) return dense_intensity(generate_volume(spec));
  if (const VolumeFormat* format = find_volume_format(spec)) return format->read_samples(spec);
  throw InputError(spec, unknown_format_message());
}

void write_label_volume(const RawVolume& labels, const std::string& source,
                        const std::string& path) {
  written_format(path).write_labels(labels_to_write(labels, source), path);
}

}  // namespace hapvox::engine::io
