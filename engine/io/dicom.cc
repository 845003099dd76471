#include "engine/io/dicom.h"

#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmScanner.h>
#include <gdcmTrace.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <sstream>
#include <vector>

#include "engine/errors.h"
#include "engine/io/child_read.h"
#include "engine/io/direction.h"
#include "engine/io/payload.h"
#include "engine/io/samples.h"
#include "engine/io/text.h"

namespace hapvox::engine::io {
namespace {

namespace fs = std::filesystem;

const gdcm::Tag kSeriesUid(0x0020, 0x000e);
const gdcm::Tag kPosition(0x0020, 0x0032);     // ImagePositionPatient
const gdcm::Tag kOrientation(0x0020, 0x0037);  // ImageOrientationPatient
const gdcm::Tag kPixelSpacing(0x0028, 0x0030);
const gdcm::Tag kSliceThickness(0x0018, 0x0050);
const gdcm::Tag kRows(0x0028, 0x0010);
const gdcm::Tag kColumns(0x0028, 0x0011);

// GDCM's warnings, kept: "Incomplete Pixel Data" there is the only sign GDCM gives of a file
// that ends inside its pixels (it reads the missing ones as zeros).
std::ostringstream& gdcm_warnings() {
  static std::ostringstream warnings;
  return warnings;
}

// GDCM reports through std::cerr unless told not to; hapvox says what went wrong itself.
// Only ever called in the reader's child process (read_dicom), whose globals these are.
void quiet_gdcm() {
  static std::once_flag once;
  std::call_once(once, [] {
    gdcm::Trace::SetDebug(false);
    gdcm::Trace::SetError(false);
    gdcm::Trace::SetWarningStream(gdcm_warnings());
    gdcm::Trace::SetWarning(true);
  });
}

// "a\b\c" -> numbers; false unless exactly `count` finite ones.
bool backslash_numbers(const char* text, std::size_t count, std::vector<double>* out) {
  if (text == nullptr) return false;
  std::string s(text);
  std::replace(s.begin(), s.end(), '\\', ' ');
  out->clear();
  for (const std::string& part : split_ws(s)) {
    double v = 0.0;
    if (!parse_double(part, &v) || !std::isfinite(v)) return false;
    out->push_back(v);
  }
  return out->size() == count;
}

struct Slice {
  std::string file;
  Vec3d position_mm;
  double along_normal_mm = 0.0;
};

const SampleTypeInfo* scalar_info(gdcm::PixelFormat::ScalarType type) {
  switch (type) {
    case gdcm::PixelFormat::UINT8:
      return &sample_type_info(SampleType::kUint8);
    case gdcm::PixelFormat::INT8:
      return &sample_type_info(SampleType::kInt8);
    case gdcm::PixelFormat::UINT12:
    case gdcm::PixelFormat::UINT16:
      return &sample_type_info(SampleType::kUint16);
    case gdcm::PixelFormat::INT12:
    case gdcm::PixelFormat::INT16:
      return &sample_type_info(SampleType::kInt16);
    case gdcm::PixelFormat::UINT32:
      return &sample_type_info(SampleType::kUint32);
    case gdcm::PixelFormat::INT32:
      return &sample_type_info(SampleType::kInt32);
    case gdcm::PixelFormat::FLOAT32:
      return &sample_type_info(SampleType::kFloat);
    case gdcm::PixelFormat::FLOAT64:
      return &sample_type_info(SampleType::kDouble);
    default:
      return nullptr;
  }
}

std::string mm(double v) {
  std::ostringstream text;
  text.precision(4);
  text << v << " mm";
  return text.str();
}

// The slices' files: a folder's regular files (by name, for a stable order before sorting by
// position), or the one file given.
std::vector<std::string> candidate_files(const std::string& path) {
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) return {path};
  if (!fs::is_directory(path, ec)) throw InputError(path, "cannot open file or folder");
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(path, ec)) {
    if (entry.is_regular_file(ec)) files.push_back(entry.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// read_dicom's work, in the child process.
RawVolume read_dicom_here(const std::string& path) {
  quiet_gdcm();
  const std::vector<std::string> files = candidate_files(path);
  gdcm::Scanner scanner;
  for (const gdcm::Tag& tag :
       {kSeriesUid, kPosition, kOrientation, kPixelSpacing, kSliceThickness, kRows, kColumns}) {
    scanner.AddTag(tag);
  }
  if (!files.empty() && !scanner.Scan(files)) throw InputError(path, "cannot scan for DICOM files");
  std::vector<std::string> dicoms;
  for (const std::string& file : files) {
    if (scanner.IsKey(file.c_str())) dicoms.push_back(file);
  }
  if (dicoms.empty()) throw InputError(path, "no DICOM file");

  // One series, one orientation, one slice size.
  const auto value = [&](const std::string& file, const gdcm::Tag& tag) {
    const char* v = scanner.GetValue(file.c_str(), tag);
    return std::string(v == nullptr ? "" : v);
  };
  const std::string series = value(dicoms.front(), kSeriesUid);
  const std::string rows_text = value(dicoms.front(), kRows);
  const std::string columns_text = value(dicoms.front(), kColumns);
  std::vector<double> iop;
  if (!backslash_numbers(scanner.GetValue(dicoms.front().c_str(), kOrientation), 6, &iop)) {
    throw InputError(dicoms.front(), "no usable ImageOrientationPatient (0020,0037)");
  }
  const Vec3d row_dir = Vec3d(iop[0], iop[1], iop[2]).normalized();
  const Vec3d column_dir = Vec3d(iop[3], iop[4], iop[5]).normalized();
  const Vec3d normal = row_dir.cross(column_dir);
  std::vector<Slice> slices;
  for (const std::string& file : dicoms) {
    if (value(file, kSeriesUid) != series) {
      throw InputError(path, "holds more than one series (" + printable(series, 64) + " and " +
                                 printable(value(file, kSeriesUid), 64) +
                                 "): give the folder of one");
    }
    if (value(file, kRows) != rows_text || value(file, kColumns) != columns_text) {
      throw InputError(file, "its slice size differs from " + dicoms.front() + "'s");
    }
    std::vector<double> own;
    if (!backslash_numbers(scanner.GetValue(file.c_str(), kOrientation), 6, &own) ||
        (Vec3d(own[0], own[1], own[2]).normalized() - row_dir).norm() > 1e-4 ||
        (Vec3d(own[3], own[4], own[5]).normalized() - column_dir).norm() > 1e-4) {
      throw InputError(file, "its ImageOrientationPatient differs from " + dicoms.front() + "'s");
    }
    std::vector<double> ipp;
    if (!backslash_numbers(scanner.GetValue(file.c_str(), kPosition), 3, &ipp)) {
      throw InputError(file, "no usable ImagePositionPatient (0020,0032)");
    }
    Slice slice{file, Vec3d(ipp[0], ipp[1], ipp[2]), 0.0};
    slice.along_normal_mm = slice.position_mm.dot(normal);
    slices.push_back(slice);
  }
  std::sort(slices.begin(), slices.end(),
            [](const Slice& a, const Slice& b) { return a.along_normal_mm < b.along_normal_mm; });

  RawVolume raw;
  raw.direction.col(0) = row_dir;
  raw.direction.col(1) = column_dir;
  raw.direction.col(2) = normal;
  if (const std::string problem = direction_problem(raw.direction); !problem.empty()) {
    throw InputError(dicoms.front(), "ImageOrientationPatient is " + problem);
  }
  raw.origin_mm = slices.front().position_mm;
  std::vector<double> pixel_spacing;
  if (!backslash_numbers(scanner.GetValue(dicoms.front().c_str(), kPixelSpacing), 2,
                         &pixel_spacing) ||
      !(pixel_spacing[0] > 0.0) || !(pixel_spacing[1] > 0.0)) {
    throw InputError(dicoms.front(), "no usable PixelSpacing (0028,0030)");
  }
  // PixelSpacing is (between rows, between columns): y first.
  raw.spacing_mm.x() = pixel_spacing[1];
  raw.spacing_mm.y() = pixel_spacing[0];
  if (slices.size() == 1) {
    std::vector<double> thickness;
    raw.spacing_mm.z() =
        backslash_numbers(scanner.GetValue(dicoms.front().c_str(), kSliceThickness), 1,
                          &thickness) &&
                thickness[0] > 0.0
            ? thickness[0]
            : 1.0;
  } else {
    const double first_step = slices[1].along_normal_mm - slices[0].along_normal_mm;
    double smallest = first_step, largest = first_step;
    for (std::size_t i = 1; i < slices.size(); ++i) {
      const double step = slices[i].along_normal_mm - slices[i - 1].along_normal_mm;
      if (step < 1e-3) {
        throw InputError(path, "two slices at one position (" + slices[i - 1].file + " and " +
                                   slices[i].file + ")");
      }
      smallest = std::min(smallest, step);
      largest = std::max(largest, step);
    }
    if (largest > 1.01 * smallest) {
      throw InputError(path, "non-uniform slice spacing (" + mm(smallest) + " to " + mm(largest) +
                                 "): resample the series first");
    }
    const Vec3d span = slices.back().position_mm - slices.front().position_mm;
    const double along = span.dot(normal);
    const double off = (span - along * normal).norm();
    if (off > 1e-3 * std::abs(along) + 1e-3) {
      const double tilt_deg = std::atan2(off, along) * 180.0 / 3.14159265358979323846;
      std::ostringstream text;
      text.precision(3);
      text << "gantry tilt: the slices step " << tilt_deg
           << " degrees off their normal (resample the series first)";
      throw InputError(path, text.str());
    }
    raw.spacing_mm.z() = along / static_cast<double>(slices.size() - 1);
  }

  // Sizes from the header before anything is allocated.
  std::int64_t rows = 0, columns = 0;
  if (!parse_int(trim(rows_text), &rows) || !parse_int(trim(columns_text), &columns) || rows <= 0 ||
      columns <= 0) {
    throw InputError(dicoms.front(), "no usable Rows/Columns (0028,0010/0011)");
  }
  const auto depth = static_cast<std::int64_t>(slices.size());
  if (rows * columns > kMaxSamples || rows * columns * depth > kMaxSamples) {
    throw InputError(path, "a " + std::to_string(columns) + " x " + std::to_string(rows) + " x " +
                               std::to_string(depth) + " series is too large (over 2^31 samples)");
  }
  const std::int64_t dims[3] = {columns, rows, depth};
  check_volume_budget(dims, sizeof(float), "", path);
  raw.dims = Vec3i(static_cast<int>(columns), static_cast<int>(rows), static_cast<int>(depth));
  const auto per_slice = static_cast<std::size_t>(rows * columns);
  raw.intensity.resize(per_slice * slices.size());

  for (std::size_t k = 0; k < slices.size(); ++k) {
    const std::string& file = slices[k].file;
    gdcm::ImageReader reader;
    reader.SetFileName(file.c_str());
    gdcm_warnings().str("");
    if (!reader.Read()) throw InputError(file, "GDCM cannot read its image");
    if (gdcm_warnings().str().find("Incomplete Pixel Data") != std::string::npos) {
      throw InputError(file, "its pixel data ends early (a truncated file)");
    }
    const gdcm::Image& image = reader.GetImage();
    const unsigned int* dims = image.GetDimensions();
    if (image.GetNumberOfDimensions() == 3 && dims[2] > 1) {
      throw InputError(file, "multi-frame images are not supported (one slice per file)");
    }
    if (dims[0] != static_cast<unsigned int>(columns) ||
        dims[1] != static_cast<unsigned int>(rows)) {
      throw InputError(file, "its image size differs from its Rows/Columns");
    }
    const gdcm::PixelFormat& format = image.GetPixelFormat();
    if (format.GetSamplesPerPixel() != 1) {
      throw InputError(file, "colour images are not supported (one sample per pixel)");
    }
    const SampleTypeInfo* type = scalar_info(format.GetScalarType());
    if (type == nullptr) throw InputError(file, "unsupported pixel format");
    raw.sample_type = type->name;
    const std::uint64_t n_bytes = per_slice * type->size;
    if (image.GetBufferLength() != n_bytes) {
      throw InputError(file, "its pixel data holds " + std::to_string(image.GetBufferLength()) +
                                 " bytes, expected " + std::to_string(n_bytes));
    }
    std::vector<unsigned char> bytes(n_bytes);
    if (!image.GetBuffer(reinterpret_cast<char*>(bytes.data()))) {
      throw InputError(file, "GDCM cannot decode its pixel data");
    }
    std::vector<float> values(per_slice);
    decode_samples(bytes, type->type, /*swap=*/false, &values, file);
    const double slope = image.GetSlope();
    const double intercept = image.GetIntercept();
    const bool inverted =
        image.GetPhotometricInterpretation() == gdcm::PhotometricInterpretation::MONOCHROME1;
    float* out = raw.intensity.data() + k * per_slice;
    for (std::size_t i = 0; i < per_slice; ++i) {
      const double v = slope * values[i] + intercept;
      out[i] = static_cast<float>(inverted ? -v : v);  // MONOCHROME1: bright is low
    }
  }
  set_min_max(&raw);
  return raw;
}

}  // namespace

RawVolume read_dicom(const std::string& path) {
  // What a series can need: its samples as floats (a compressed slice inflates up to ~10x its
  // file: 12x covers the floats of a 2-byte sample besides), plus 256 MiB for GDCM's own
  // (its dictionaries are mapped before the fork).
  std::uint64_t file_bytes = 0;
  std::error_code ec;
  for (const std::string& file : candidate_files(path)) {
    const std::uintmax_t size = fs::file_size(file, ec);
    if (!ec) file_bytes += size;
  }
  return read_in_child_process(path, read_dicom_here, "GDCM",
                               (std::uint64_t{256} << 20) + 12 * file_bytes);
}

}  // namespace hapvox::engine::io
