#include "engine/io/nifti.h"

#include <fcntl.h>
#include <nifti2_io.h>
#include <unistd.h>
#include <zlib.h>

#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <vector>

#include "engine/errors.h"
#include "engine/input_limits.h"
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

// nifticlib prints some errors to stderr whatever its debug level (nifti2_io.c's ERREX and
// LNI_FERR: "** ERROR: nifti_convert_n1hdr2nim: bad dim[1]"), which broke hapvox's one line
// in three. While it reads a header, stderr goes into a pipe (non-blocking: what does not fit
// is dropped), and its first message is folded into our line. Under nifti_mutex(); another
// thread's stderr in that window would land there too, and hapvox reads volumes before it
// starts threads.
class NiftiChatter {
 public:
  NiftiChatter() {
    int fds[2];
    if (pipe2(fds, O_NONBLOCK | O_CLOEXEC) != 0) return;
    read_end_ = fds[0];
    std::fflush(stderr);
    saved_ = dup(STDERR_FILENO);
    if (saved_ < 0 || dup2(fds[1], STDERR_FILENO) < 0) restore();
    close(fds[1]);
  }
  ~NiftiChatter() {
    restore();
    if (read_end_ >= 0) close(read_end_);
  }
  NiftiChatter(const NiftiChatter&) = delete;
  NiftiChatter& operator=(const NiftiChatter&) = delete;

  /// nifticlib's first line, without its "** ERROR (...): " prefix ("" when it said nothing).
  std::string first_line() {
    restore();
    std::string text;
    char piece[512];
    for (ssize_t got; read_end_ >= 0 && (got = read(read_end_, piece, sizeof piece)) > 0;) {
      text.append(piece, static_cast<std::size_t>(got));
    }
    std::string line = text.substr(0, text.find('\n'));
    const auto prefix_end = line.rfind("): ");
    if (line.starts_with("** ") && prefix_end != std::string::npos) {
      line.erase(0, prefix_end + 3);
    } else if (const auto colon = line.rfind(": "); line.starts_with("** ") && colon != line.npos) {
      line.erase(0, colon + 2);
    }
    return trim(line);
  }

 private:
  void restore() {
    if (saved_ < 0) return;
    std::fflush(stderr);
    dup2(saved_, STDERR_FILENO);
    close(saved_);
    saved_ = -1;
  }
  int read_end_ = -1;
  int saved_ = -1;
};

// nifticlib makes a non-finite pixdim 1 (nifti_convert_n1hdr2nim's "set bad grid spacings to
// 1.0"): a NaN became 1 mm without a word. The spatial pixdims are checked in the header's own
// bytes, and a non-finite one refused (a zero one stays 1, as nifticlib has it).
// gzread reads a plain file as it is. A header too short or of no known size is left to
// nifticlib, which says so.
void check_raw_pixdims(const std::string& path) {
  const gzFile file = gzopen(path.c_str(), "rb");
  if (file == nullptr) return;
  unsigned char bytes[sizeof(nifti_2_header)] = {};
  const int got = gzread(file, bytes, sizeof bytes);
  gzclose(file);
  std::int32_t header_size = 0;
  std::memcpy(&header_size, bytes, sizeof header_size);
  const bool swap = header_size != 348 && header_size != 540;
  if (swap) nifti_swap_4bytes(1, &header_size);
  const bool two = header_size == 540;
  if ((header_size != 348 && !two) || got < header_size) return;
  for (int a = 1; a <= 3; ++a) {
    double pixdim = 0.0;
    if (two) {
      std::memcpy(&pixdim, bytes + offsetof(nifti_2_header, pixdim) + 8 * a, 8);
      if (swap) nifti_swap_8bytes(1, &pixdim);
    } else {
      float single = 0.0F;
      std::memcpy(&single, bytes + offsetof(nifti_1_header, pixdim) + 4 * a, 4);
      if (swap) nifti_swap_4bytes(1, &single);
      pixdim = single;
    }
    if (!std::isfinite(pixdim)) {
      throw InputError(path, "pixdim[" + std::to_string(a) + "] is " +
                                 (std::isnan(pixdim) ? "NaN" : "infinite") +
                                 " (a voxel size must be a finite number of units)");
    }
  }
}

ImagePtr read_header_only(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path, "cannot open file");
  std::lock_guard lock(nifti_mutex());
  ImagePtr image;
  std::string said;
  {
    NiftiChatter chatter;
    image.reset(nifti_image_read(path.c_str(), /*read_data=*/0));
    said = chatter.first_line();
  }
  if (image == nullptr) {
    throw InputError(path, "not a NIfTI file (its header does not parse as NIfTI-1 or -2" +
                               (said.empty() ? "" : ": " + printable(said, 120)) + ")");
  }
  check_raw_pixdims(path);
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
  check_volume_budget(sizes, type->size, type->name, path);

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
