#include "engine/io/nifti.h"

#include <nifti2_io.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <vector>

#include "engine/errors.h"
#include "engine/io/direction.h"
#include "engine/io/payload.h"
#include "engine/io/samples.h"
#include "engine/io/text.h"

namespace hapvox::engine::io {
namespace {

namespace fs = std::filesystem;

struct FreeImage {
  void operator()(nifti_image* image) const { nifti_image_free(image); }
};
using ImagePtr = std::unique_ptr<nifti_image, FreeImage>;

// nifticlib keeps its options in globals and prints to stderr: quiet it once. Its reads
// are not known to be thread-safe, so one at a time.
std::mutex& nifti_mutex() {
  static std::mutex mutex;
  static std::once_flag once;
  std::call_once(once, [] { nifti_set_debug_level(0); });
  return mutex;
}

int nifti_datatype(WrittenType type) {
  switch (type) {
    case WrittenType::float32:
      return DT_FLOAT32;
    case WrittenType::uint8:
      return DT_UINT8;
    case WrittenType::uint16:
      return DT_UINT16;
    case WrittenType::int32:
      return DT_INT32;
  }
  return DT_UNKNOWN;
}

const SampleTypeInfo* datatype_info(int datatype) {
  switch (datatype) {
    case DT_INT8:
      return &sample_type_info(SampleType::kInt8);
    case DT_UINT8:
      return &sample_type_info(SampleType::kUint8);
    case DT_INT16:
      return &sample_type_info(SampleType::kInt16);
    case DT_UINT16:
      return &sample_type_info(SampleType::kUint16);
    case DT_INT32:
      return &sample_type_info(SampleType::kInt32);
    case DT_UINT32:
      return &sample_type_info(SampleType::kUint32);
    case DT_INT64:
      return &sample_type_info(SampleType::kInt64);
    case DT_UINT64:
      return &sample_type_info(SampleType::kUint64);
    case DT_FLOAT32:
      return &sample_type_info(SampleType::kFloat);
    case DT_FLOAT64:
      return &sample_type_info(SampleType::kDouble);
    default:
      return nullptr;
  }
}

// Millimetres per unit of the header's spatial unit (unknown: millimetres, as Slicer reads).
double mm_per_unit(int xyz_units) {
  switch (XYZT_TO_SPACE(xyz_units)) {
    case NIFTI_UNITS_METER:
      return 1000.0;
    case NIFTI_UNITS_MICRON:
      return 0.001;
    default:
      return 1.0;
  }
}

ImagePtr read_header_only(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path, "cannot open file");
  std::lock_guard lock(nifti_mutex());
  ImagePtr image(nifti_image_read(path.c_str(), /*read_data=*/0));
  if (image == nullptr) {
    throw InputError(path, "not a NIfTI file (its header does not parse as NIfTI-1 or -2)");
  }
  return image;
}

bool ends_with_gz(const std::string& path) {
  const std::string name = lower(path);
  return name.size() > 3 && ends_with(name, ".gz");
}

}  // namespace

std::string nifti_data_file(const std::string& path) {
  const ImagePtr image = read_header_only(path);
  if (image->iname == nullptr || image->fname == nullptr) return "";
  return std::strcmp(image->iname, image->fname) == 0 ? "" : std::string(image->iname);
}

RawVolume read_nifti(const std::string& path) {
  const ImagePtr image = read_header_only(path);
  const nifti_image& nim = *image;
  if (nim.ndim < 3 || nim.nt > 1 || nim.nu > 1 || nim.nv > 1 || nim.nw > 1) {
    throw InputError(path, "a " + std::to_string(nim.ndim) +
                               "-D image is not supported (only 3-D scalar volumes are)");
  }
  const SampleTypeInfo* type = datatype_info(nim.datatype);
  if (type == nullptr) {
    throw InputError(path, std::string("unsupported datatype ") +
                               nifti_datatype_string(nim.datatype) +
                               " (expected an integer or float scalar)");
  }
  RawVolume raw;
  raw.sample_type = type->name;
  std::int64_t samples = 1;
  const std::int64_t sizes[3] = {nim.nx, nim.ny, nim.nz};
  for (int a = 0; a < 3; ++a) {
    if (sizes[a] <= 0 || sizes[a] > kMaxSamples || samples * sizes[a] > kMaxSamples) {
      throw InputError(path, "dimensions " + std::to_string(nim.nx) + " x " +
                                 std::to_string(nim.ny) + " x " + std::to_string(nim.nz) +
                                 " are empty or too large (over 2^31 samples)");
    }
    samples *= sizes[a];
    raw.dims[a] = static_cast<int>(sizes[a]);
  }

  // Index -> RAS millimetres, then into LPS: negate the x and y rows.
  const double unit = mm_per_unit(nim.xyz_units);
  Eigen::Matrix3d axes;
  Vec3d origin;
  if (nim.sform_code > 0 || nim.qform_code > 0) {
    const nifti_dmat44& m = nim.sform_code > 0 ? nim.sto_xyz : nim.qto_xyz;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) axes(r, c) = m.m[r][c];
      origin[r] = m.m[r][3];
    }
  } else {  // "method 1": the voxel sizes, no rotation
    axes = Vec3d(nim.dx, nim.dy, nim.dz).asDiagonal();
    origin.setZero();
  }
  const Vec3d ras_to_lps(-1.0, -1.0, 1.0);
  axes = ras_to_lps.asDiagonal() * axes * unit;
  raw.origin_mm = ras_to_lps.cwiseProduct(origin) * unit;
  const char* which = nim.sform_code > 0 ? "sform" : nim.qform_code > 0 ? "qform" : "pixdim";
  for (int a = 0; a < 3; ++a) {
    raw.spacing_mm[a] = axes.col(a).norm();
    if (!std::isfinite(raw.spacing_mm[a]) || !(raw.spacing_mm[a] > 0.0)) {
      throw InputError(path, std::string(which) + " gives axis " + std::to_string(a) +
                                 " a spacing that is not positive and finite");
    }
    raw.direction.col(a) = axes.col(a) / raw.spacing_mm[a];
  }
  if (!raw.origin_mm.allFinite())
    throw InputError(path, std::string(which) + " origin is not finite");
  if (const std::string problem = direction_problem(raw.direction); !problem.empty()) {
    throw InputError(path, std::string(which) + " axes are " + problem);
  }
  raw.holds_density = std::strncmp(nim.intent_name, "hapvox_density", sizeof nim.intent_name) == 0;
  raw.holds_labels = nim.intent_code == NIFTI_INTENT_LABEL;

  // The payload, read here with bounded allocation: nifticlib would allocate what the
  // header claims before reading a byte.
  const std::string data_path = nim.iname != nullptr ? nim.iname : path;
  std::ifstream data(data_path, std::ios::binary);
  if (!data) throw InputError(path, "cannot open data file '" + data_path + "'");
  const auto n_bytes = static_cast<std::uint64_t>(samples) * type->size;
  const std::vector<unsigned char> bytes = ends_with_gz(data_path)
                                               ? read_gzip(data, nim.iname_offset, n_bytes, path)
                                               : read_raw(data, nim.iname_offset, n_bytes, path);
  constexpr int kMsbFirst = 2;  // nifticlib's MSB_FIRST, not exported by nifti2_io.h
  const bool big_endian = nim.byteorder == kMsbFirst;
  const bool swap = type->size > 1 && big_endian != (std::endian::native == std::endian::big);
  raw.intensity.resize(static_cast<std::size_t>(samples));
  decode_samples(bytes, type->type, swap, &raw.intensity, path);
  if (nim.scl_slope != 0.0 && std::isfinite(nim.scl_slope) && std::isfinite(nim.scl_inter) &&
      !(nim.scl_slope == 1.0 && nim.scl_inter == 0.0)) {
    for (float& v : raw.intensity) {
      v = static_cast<float>(nim.scl_slope * v + nim.scl_inter);
    }
  }
  set_min_max(&raw);
  return raw;
}

void write_nifti(const DensityField& field, const std::string& path) {
  write_nifti_volume(density_to_write(field), path);
}

void write_nifti_volume(const WrittenVolume& volume, const std::string& path) {
  if (lower(fs::path(path).extension().string()) == ".hdr") {
    throw InputError(path, "hapvox writes NIfTI as one file, .nii or .nii.gz, not .hdr/.img");
  }
  const bool labels = volume.content == WrittenContent::labels;
  const Vec3i& d = volume.dims;
  const std::int64_t dims[8] = {3, d.x(), d.y(), d.z(), 1, 1, 1, 1};
  nifti_1_header header{};
  {
    std::lock_guard lock(nifti_mutex());
    const ImagePtr image(nifti_make_new_nim(dims, nifti_datatype(volume.type), /*data_fill=*/0));
    if (image == nullptr) throw InputError(path, "cannot make a NIfTI header");
    nifti_image& nim = *image;
    // LPS -> RAS: negate the x and y rows.
    const Vec3d lps_to_ras(-1.0, -1.0, 1.0);
    const Eigen::Matrix3d axes =
        lps_to_ras.asDiagonal() * volume.direction * volume.spacing_mm.asDiagonal();
    const Vec3d origin = lps_to_ras.cwiseProduct(volume.origin_mm);
    nifti_dmat44 m{};
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) m.m[r][c] = axes(r, c);
      m.m[r][3] = origin[r];
    }
    m.m[3][3] = 1.0;
    nim.sto_xyz = m;
    nim.sform_code = NIFTI_XFORM_SCANNER_ANAT;
    nim.qform_code = NIFTI_XFORM_SCANNER_ANAT;
    nifti_dmat44_to_quatern(m, &nim.quatern_b, &nim.quatern_c, &nim.quatern_d, &nim.qoffset_x,
                            &nim.qoffset_y, &nim.qoffset_z, &nim.dx, &nim.dy, &nim.dz, &nim.qfac);
    nim.pixdim[1] = nim.dx;
    nim.pixdim[2] = nim.dy;
    nim.pixdim[3] = nim.dz;
    nim.xyz_units = NIFTI_UNITS_MM;
    nim.nifti_type = NIFTI_FTYPE_NIFTI1_1;
    nim.iname_offset = 352;  // the 348-byte header and 4 bytes of "no extensions"
    // NIFTI_INTENT_LABEL is the standard's "this is a label map" (Slicer, FSL, ITK-SNAP).
    if (labels) nim.intent_code = NIFTI_INTENT_LABEL;
    std::strncpy(nim.intent_name, labels ? "hapvox_labels" : "hapvox_density",
                 sizeof nim.intent_name - 1);
    std::strncpy(nim.descrip, labels ? "hapvox label map" : "hapvox density in [0, 1]",
                 sizeof nim.descrip - 1);
    if (nifti_convert_nim2n1hdr(&nim, &header) != 0) {
      throw InputError(path, "cannot make a NIfTI header");
    }
  }
  std::vector<unsigned char> file(352, 0);
  std::memcpy(file.data(), &header, sizeof header);
  file.insert(file.end(), volume.bytes.begin(), volume.bytes.end());
  if (ends_with_gz(path)) {
    const std::vector<unsigned char> packed =
        deflate_bytes(file.data(), file.size(), /*gzip=*/true);
    write_file_atomically(path, {{packed.data(), packed.size()}});
  } else {
    write_file_atomically(path, {{file.data(), file.size()}});
  }
}

}  // namespace hapvox::engine::io
