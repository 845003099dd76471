#include "engine/io/nifti.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/io/io_test_util.h"
#include "engine/volume_io.h"
#include "test_data.h"

namespace hapvox::engine {
namespace {

using ::hapvox::testing::scratch_dir;
using ::testing::HasSubstr;
using namespace ::hapvox::engine::io_test;  // NOLINT(build/namespaces)

// A NIfTI-1 header written byte by byte from the standard (nifti1.h's field offsets), not
// by nifticlib: sizeof_hdr 348, dim at 40, datatype 70, bitpix 72, pixdim 76, vox_offset
// 108, scl_slope 112, scl_inter 116, xyzt_units 123, qform_code 252, sform_code 254,
// srow_x/y/z 280/296/312, intent_name 328, magic 344.
struct Nifti1 {
  std::vector<std::int16_t> dim = {3, 2, 3, 2, 1, 1, 1, 1};
  std::int16_t datatype = 4;  // DT_INT16
  std::int16_t bitpix = 16;
  std::vector<float> pixdim = {1, 0.5f, 0.75f, 2, 1, 1, 1, 1};
  float scl_slope = 0.0f;
  float scl_inter = 0.0f;
  char xyzt_units = 2;  // mm
  std::int16_t qform_code = 0;
  std::int16_t sform_code = 1;
  float srow[3][4] = {{-0.5f, 0, 0, 10}, {0, 0.75f, 0, -20}, {0, 0, 2, 30}};  // RAS

  std::string bytes() const {
    std::string h(352, '\0');
    auto put = [&h](std::size_t at, const void* v, std::size_t n) { std::memcpy(&h[at], v, n); };
    const std::int32_t size = 348;
    put(0, &size, 4);
    put(40, dim.data(), 16);
    put(70, &datatype, 2);
    put(72, &bitpix, 2);
    put(76, pixdim.data(), 32);
    const float vox_offset = 352.0f;
    put(108, &vox_offset, 4);
    put(112, &scl_slope, 4);
    put(116, &scl_inter, 4);
    put(123, &xyzt_units, 1);
    put(252, &qform_code, 2);
    put(254, &sform_code, 2);
    put(280, srow[0], 16);
    put(296, srow[1], 16);
    put(312, srow[2], 16);
    put(344, "n+1\0", 4);
    return h;
  }
};

// scratch_dir() empties the test's folder: each test asks once and passes it on.
std::string write_nii(const std::string& dir, const std::string& name,
                      const std::string& contents) {
  const std::string path = dir + "/" + name;
  write_file(path, contents);
  return path;
}

const std::vector<std::int16_t> kTwelve = {-1000, -1, 0, 1, 2, 3, 40, 50, 60, 700, 800, 32767};

TEST(VolumeIoNifti, ReadsSformIntoLpsWithScaling) {
  const std::string dir = scratch_dir();
  Nifti1 n;
  n.scl_slope = 2.0f;
  n.scl_inter = -1024.0f;  // CT's usual rescale to Hounsfield units
  const std::string raw = n.bytes() + to_bytes(kTwelve, false);
  for (const std::string name : {"ct.nii", "ct.nii.gz"}) {
    const std::string path = write_nii(dir, name, name == "ct.nii" ? raw : gzip(raw));
    const io::RawVolume v = io::read_nifti(path);
    EXPECT_EQ(v.dims, Vec3i(2, 3, 2)) << name;
    EXPECT_TRUE(v.spacing_mm.isApprox(Vec3d(0.5, 0.75, 2.0), 1e-7)) << v.spacing_mm;
    // RAS (-0.5, 0, 0) per i is LPS (+0.5, 0, 0): i runs along +x; RAS +y is LPS -y.
    EXPECT_TRUE(v.direction.isApprox(Vec3d(1, -1, 1).asDiagonal().toDenseMatrix(), 1e-7))
        << v.direction;
    EXPECT_TRUE(v.origin_mm.isApprox(Vec3d(-10, 20, 30), 1e-7)) << v.origin_mm;
    EXPECT_EQ(v.sample_type, "int16");
    for (std::size_t i = 0; i < kTwelve.size(); ++i) {
      EXPECT_EQ(v.intensity[i], 2.0f * kTwelve[i] - 1024.0f) << i;
    }
  }
}

TEST(VolumeIoNifti, QformOrPixdimWhenNoSform) {
  const std::string dir = scratch_dir();
  Nifti1 n;
  n.sform_code = 0;  // no sform, no qform: pixdim alone, identity in RAS
  n.xyzt_units = 1;  // metres
  n.pixdim = {1, 0.001f, 0.002f, 0.003f, 1, 1, 1, 1};
  const io::RawVolume v =
      io::read_nifti(write_nii(dir, "pixdim.nii", n.bytes() + to_bytes(kTwelve, false)));
  EXPECT_TRUE(v.spacing_mm.isApprox(Vec3d(1, 2, 3), 1e-5)) << v.spacing_mm;
  EXPECT_TRUE(v.direction.isApprox(Vec3d(-1, -1, 1).asDiagonal().toDenseMatrix(), 1e-7));
}

TEST(VolumeIoNifti, WriteReadRoundTripKeepsVoxelsAndOrientation) {
  const std::string dir = scratch_dir();
  const DensityField plain = make_test_field();
  const Mat3d turn = Eigen::AngleAxisd(0.4, Vec3d(0, 0, 1)).toRotationMatrix();
  const DensityField field(plain.grid().deepCopy(), plain.voxel_size_mm(), plain.origin_mm(),
                           plain.dims(), turn);
  for (const std::string name : {"d.nii", "d.nii.gz"}) {
    const std::string path = dir + "/" + name;
    io::write_nifti(field, path);
    const io::RawVolume raw = io::read_nifti(path);
    EXPECT_TRUE(raw.holds_density);
    // The header stores the affine as 32-bit floats.
    EXPECT_TRUE(raw.direction.isApprox(turn, 1e-6)) << raw.direction;
    EXPECT_TRUE(raw.spacing_mm.isApprox(field.voxel_size_mm(), 1e-6));
    EXPECT_TRUE(raw.origin_mm.isApprox(field.origin_mm(), 1e-6));
    const DensityField back = load_volume(path, {});
    EXPECT_EQ(back.active_voxel_count(), field.active_voxel_count());
    EXPECT_EQ(back.total_density(), field.total_density());
    auto acc = back.grid().getConstAccessor();
    for (auto it = field.grid().cbeginValueOn(); it; ++it) {
      ASSERT_EQ(acc.getValue(it.getCoord()), *it) << it.getCoord();
    }
  }
  expect_input_error([&] { io::write_nifti(field, dir + "/d.hdr"); }, dir + "/d.hdr",
                     "not .hdr/.img");
}

TEST(VolumeIoNiftiRealData, MricronTemplatesOpenAsNibabelReadsThem) {
  // Debian's mricron-data (scripts/setup.sh installs it); expected values from nibabel 5.0's
  // affine of each file, turned from RAS into LPS.
  const std::string dir = "/usr/share/mricron/templates/";
  ASSERT_TRUE(std::filesystem::exists(dir + "AICHAmc.nii.gz"))
      << "Debian's mricron-data is missing: scripts/setup.sh installs it";
  const io::RawVolume aicha = io::read_nifti(dir + "AICHAmc.nii.gz");
  EXPECT_EQ(aicha.dims, Vec3i(91, 109, 91));
  EXPECT_EQ(aicha.spacing_mm, Vec3d(2, 2, 2));
  EXPECT_EQ(aicha.direction, Vec3d(1, -1, 1).asDiagonal().toDenseMatrix());
  EXPECT_EQ(aicha.origin_mm, Vec3d(-90, 126, -72));
  const io::RawVolume jhu = io::read_nifti(dir + "JHU-WhiteMatter-labels-2mm.nii.gz");
  EXPECT_EQ(jhu.dims, Vec3i(91, 109, 91));
  EXPECT_EQ(jhu.direction, Vec3d(-1, -1, 1).asDiagonal().toDenseMatrix());
  EXPECT_EQ(jhu.origin_mm, Vec3d(90, 126, -72));
  EXPECT_EQ(jhu.sample_type, "uint8");
}

TEST(VolumeIoNiftiErrors, EveryBadFileNamesTheProblem) {
  const std::string dir = scratch_dir();
  const std::string data = to_bytes(kTwelve, false);
  expect_input_error([&] { io::read_nifti(dir + "/none.nii"); }, dir + "/none.nii",
                     "cannot open file");
  const std::string junk = write_nii(dir, "junk.nii", std::string(400, 'x'));
  expect_input_error([&] { io::read_nifti(junk); }, junk, "not a NIfTI file");
  Nifti1 four;
  four.dim = {4, 2, 3, 2, 5, 1, 1, 1};
  const std::string p4 = write_nii(dir, "4d.nii", four.bytes() + data + data + data + data + data);
  expect_input_error([&] { io::read_nifti(p4); }, p4, "a 4-D image is not supported");
  Nifti1 rgb;
  rgb.datatype = 128;  // DT_RGB24
  rgb.bitpix = 24;
  const std::string prgb = write_nii(dir, "rgb.nii", rgb.bytes() + std::string(36, '\0'));
  expect_input_error([&] { io::read_nifti(prgb); }, prgb, "unsupported datatype");
  Nifti1 shear;
  shear.srow[0][1] = 0.3f;
  const std::string ps = write_nii(dir, "shear.nii", shear.bytes() + data);
  expect_input_error([&] { io::read_nifti(ps); }, ps, "sform axes are not orthonormal");
  const std::string pshort = write_nii(dir, "short.nii", Nifti1{}.bytes() + data.substr(0, 10));
  expect_input_error([&] { io::read_nifti(pshort); }, pshort, "truncated data");
  const std::string pz = write_nii(dir, "bad.nii.gz", gzip(Nifti1{}.bytes()) + "garbage");
  expect_input_error([&] { io::read_nifti(pz); }, pz, "truncated data");
}

TEST(VolumeIoNiftiErrors, AbsurdSizeIsRefusedBeforeAllocating) {
  const std::string dir = scratch_dir();
  Nifti1 huge;
  huge.dim = {3, 30000, 30000, 30000, 1, 1, 1, 1};
  const std::string path = write_nii(dir, "huge.nii", huge.bytes() + "tiny");
  expect_input_error([&] { io::read_nifti(path); }, path, "too large (over 2^31 samples)");
}

TEST(VolumeIoNiftiErrors, AHeaderOverTheInputBudgetIsRefusedBeforeReadingItsData) {
  const std::string dir = scratch_dir();
  Nifti1 big;  // 1250^3 float32: 7.3 GiB decoded, from a file of a few hundred bytes
  big.dim = {3, 1250, 1250, 1250, 1, 1, 1, 1};
  big.datatype = 16;
  big.bitpix = 32;
  const std::string path = write_nii(dir, "big.nii.gz", gzip(big.bytes() + std::string(64, '\0')));
  expect_input_error([&] { io::read_nifti(path); }, path,
                     "1250 x 1250 x 1250 float samples take 7451 MB decoded, over the limit of "
                     "2048 MB (raise it with --max-input-mb)");
}

TEST(VolumeIoNiftiErrors, NiftiClibsOwnErrorLinesAreFoldedIntoOurs) {
  // nifticlib printed "** ERROR: nifti_convert_n1hdr2nim: bad datatype" on stderr before
  // hapvox's line: three lines for one problem.
  const std::string dir = scratch_dir();
  Nifti1 untyped;
  untyped.datatype = 0;  // DT_UNKNOWN
  const std::string path = write_nii(dir, "untyped.nii", untyped.bytes() + "xx");
  ::testing::internal::CaptureStderr();
  const std::string what = hapvox::testing::input_error_of([&] { io::read_nifti(path); });
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
  EXPECT_EQ(what, path +
                      ": not a NIfTI file (its header does not parse as NIfTI-1 or -2: "
                      "bad datatype)");
}

TEST(VolumeIoNiftiErrors, ANonFinitePixdimIsRefusedNotMadeOneMillimetre) {
  const std::string dir = scratch_dir();
  const std::string data = to_bytes(kTwelve, false);
  Nifti1 nan;
  nan.sform_code = 0;  // the pixdims are the spacing
  nan.pixdim[2] = std::nanf("");
  const std::string pnan = write_nii(dir, "nan.nii", nan.bytes() + data);
  expect_input_error([&] { io::read_nifti(pnan); }, pnan,
                     "pixdim[2] is NaN (a voxel size must be a finite number of units)");
  Nifti1 inf = nan;
  inf.pixdim[2] = 0.75f;
  inf.pixdim[3] = INFINITY;
  const std::string pinf = write_nii(dir, "inf.nii.gz", gzip(inf.bytes() + data));
  expect_input_error([&] { io::read_nifti(pinf); }, pinf, "pixdim[3] is infinite");
}

}  // namespace
}  // namespace hapvox::engine
