// Label maps written as integers by every writer: the smallest type that holds the labels,
// metadata saying "labels", and a read that gives back every label and the geometry.

#include "engine/io/written_volume.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "engine/io/formats.h"
#include "engine/io/io_test_util.h"
#include "engine/io/nifti.h"
#include "engine/io/nrrd.h"

namespace hapvox::engine::io {
namespace {

using namespace ::hapvox::engine::io_test;  // NOLINT(build/namespaces)

// A 5x4x3 label map on a turned, anisotropic grid: background 0, labels up to `largest`.
RawVolume turned_labels(float largest) {
  RawVolume labels;
  labels.dims = Vec3i(5, 4, 3);
  labels.spacing_mm = Vec3d(0.7, 1.1, 2.5);
  labels.origin_mm = Vec3d(-12.5, 30.25, 7.0);
  labels.direction = Eigen::AngleAxisd(0.6, Vec3d(1, -2, 0.5).normalized()).toRotationMatrix();
  labels.sample_type = "float";
  for (int i = 0; i < 60; ++i) labels.intensity.push_back(static_cast<float>(i % 4));
  labels.intensity[17] = largest;
  return labels;
}

TEST(WrittenVolume, LabelsTakeTheSmallestIntegerTypeThatHoldsThem) {
  EXPECT_EQ(labels_to_write(turned_labels(255), "m").type, WrittenType::uint8);
  EXPECT_EQ(labels_to_write(turned_labels(256), "m").type, WrittenType::uint16);
  EXPECT_EQ(labels_to_write(turned_labels(65535), "m").type, WrittenType::uint16);
  EXPECT_EQ(labels_to_write(turned_labels(65536), "m").type, WrittenType::int32);
  EXPECT_EQ(labels_to_write(turned_labels(1 << 24), "m").type, WrittenType::int32);
  const WrittenVolume written = labels_to_write(turned_labels(300), "m");
  EXPECT_EQ(written.bytes.size(), 60u * 2u);
  const std::vector<std::int32_t> back = written_labels(written);
  ASSERT_EQ(back.size(), 60u);
  EXPECT_EQ(back[17], 300);
  EXPECT_EQ(back[7], 3);
}

TEST(WrittenVolume, ANonLabelIsRefusedNamingItsVoxel) {
  // Voxel 23 of a 5x4x3 grid is (3, 0, 1).
  for (const float bad : {2.5f, -1.0f, 16777217.0f * 2.0f}) {
    RawVolume labels = turned_labels(3);
    labels.intensity[23] = bad;
    expect_input_error([&] { labels_to_write(labels, "seg.nrrd"); }, "seg.nrrd",
                       "voxel (3, 0, 1) holds");
  }
  RawVolume nan = turned_labels(3);
  nan.intensity[0] = std::nanf("");
  expect_input_error([&] { labels_to_write(nan, "seg.nrrd"); }, "seg.nrrd",
                     "voxel (0, 0, 0) holds nan, not a label (an integer in [0, 16777216])");
}

TEST(WrittenVolume, EveryWriterRoundTripsLabelsAsIntegers) {
  int writers = 0;
  for (const VolumeFormat& format : volume_formats()) {
    if (format.write == nullptr) continue;
    ASSERT_NE(format.write_labels, nullptr) << format.name;
    const std::vector<std::string>& extensions =
        format.written_extensions.empty() ? format.extensions : format.written_extensions;
    for (const std::string& ext : extensions) {
      ++writers;
      for (const float largest : {200.0f, 40000.0f, 70000.0f}) {
        const RawVolume labels = turned_labels(largest);
        const std::string path = scratch_dir() + "/labels" + ext;
        write_label_volume(labels, "seg", path);
        const RawVolume back = read_scalar_volume(path);
        const std::string what = ext + " " + std::to_string(largest);
        // NIfTI-1 stores its affine as 32-bit floats; the others as written.
        const double tol = format.name == std::string("NIfTI") ? 1e-6 : 1e-14;
        EXPECT_EQ(back.dims, labels.dims) << what;
        EXPECT_TRUE(back.spacing_mm.isApprox(labels.spacing_mm, tol)) << what;
        EXPECT_TRUE(back.origin_mm.isApprox(labels.origin_mm, tol)) << what;
        EXPECT_TRUE(back.direction.isApprox(labels.direction, tol)) << what;
        EXPECT_EQ(back.intensity, labels.intensity) << what;
        EXPECT_FALSE(back.holds_density) << what;
        EXPECT_TRUE(back.holds_labels) << what;
        // OpenVDB has one integer grid type for it; the others the smallest that fits.
        const std::string expected = format.name == std::string("OpenVDB") ? "int32"
                                     : largest < 256                       ? "uint8"
                                     : largest < 65536                     ? "uint16"
                                                                           : "int32";
        EXPECT_EQ(back.sample_type, expected) << what;
      }
    }
  }
  EXPECT_EQ(writers, 7);  // .nrrd .nhdr .vdb .mha .mhd .nii .nii.gz
}

TEST(WrittenVolume, HeadersSayTheFileHoldsALabelMap) {
  const RawVolume labels = turned_labels(9);
  const std::string dir = scratch_dir();
  write_label_volume(labels, "seg", dir + "/l.nrrd");
  const std::string nrrd = read_file(dir + "/l.nrrd");
  EXPECT_NE(nrrd.find("\ntype: uint8\n"), std::string::npos) << nrrd.substr(0, 400);
  EXPECT_NE(nrrd.find("\nhapvox_content:=labels\n"), std::string::npos);
  write_label_volume(labels, "seg", dir + "/l.mha");
  const std::string mha = read_file(dir + "/l.mha");
  EXPECT_NE(mha.find("\nElementType = MET_UCHAR\n"), std::string::npos);
  EXPECT_NE(mha.find("\nHapvoxContent = labels\n"), std::string::npos);
  // NIfTI-1: intent_code (int16) at byte 68 is NIFTI_INTENT_LABEL (1002), datatype at 70
  // DT_UINT8 (2), intent_name at 328.
  write_label_volume(labels, "seg", dir + "/l.nii");
  const std::string nii = read_file(dir + "/l.nii");
  ASSERT_GE(nii.size(), 352u + 60u);
  std::int16_t intent_code = 0, datatype = 0;
  std::memcpy(&intent_code, nii.data() + 68, 2);
  std::memcpy(&datatype, nii.data() + 70, 2);
  EXPECT_EQ(intent_code, 1002);
  EXPECT_EQ(datatype, 2);
  EXPECT_EQ(std::string(nii.data() + 328), "hapvox_labels");
  EXPECT_EQ(nii.size(), 352u + 60u);  // one byte per label
}

TEST(WrittenVolume, NiftiPairsAreReadButNotWritten) {
  EXPECT_EQ(find_written_format("a.hdr"), nullptr);
  EXPECT_STREQ(find_written_format("a.NII.GZ")->name, "NIfTI");
  EXPECT_EQ(find_written_format("a.dcm"), nullptr);
  EXPECT_EQ(find_written_format("a.raw"), nullptr);
  expect_input_error([&] { write_label_volume(turned_labels(3), "seg", "out.hdr"); }, "out.hdr",
                     "unknown output format (expected .nrrd, .nhdr, .vdb, .mha, .mhd, .nii or "
                     ".nii.gz)");
}

}  // namespace
}  // namespace hapvox::engine::io
