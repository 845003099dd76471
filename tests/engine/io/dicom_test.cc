#include "engine/io/dicom.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/io/io_test_util.h"
#include "engine/volume_io.h"
#include "test_data.h"

namespace hapvox::engine {
namespace {

using namespace ::hapvox::engine::io_test;  // NOLINT(build/namespaces)

// pydicom's own test files (Debian's python3-pydicom; scripts/setup.sh installs it).
const std::string kPydicomFiles = "/usr/lib/python3/dist-packages/pydicom/data/test_files/";

// Writes a series with pydicom from CT_small.dcm: slice k (0..n-1) at base + k * step_mm *
// normal (+ k * shift_mm along the row direction: a gantry tilt), its pixels CT_small's plus
// 100 k, files named in a shuffled order with random instance numbers, and a text file
// beside them. `orientation` is ImageOrientationPatient; `positions_mm` overrides the steps.
void write_series(const std::string& dir, int n, const std::string& orientation, double step_mm,
                  double shift_mm, const std::string& positions_mm = "",
                  bool second_series = false) {
  const std::string script =
      "import copy, random, numpy as np, pydicom\n"
      "from pydicom.uid import generate_uid\n"
      "from pydicom.valuerep import DSfloat as DS\n"
      "src = pydicom.dcmread('" +
      kPydicomFiles +
      "CT_small.dcm')\n"
      "n = " +
      std::to_string(n) +
      "\n"
      "iop = [" +
      orientation +
      "]\n"
      "row, col = np.array(iop[:3]), np.array(iop[3:])\n"
      "normal = np.cross(row, col)\n"
      "base = np.array([-158.135803, -179.035797, -75.699997])\n"
      "steps = [" +
      (positions_mm.empty() ? "k * " + std::to_string(step_mm) + " for k in range(n)"
                            : positions_mm) +
      "]\n"
      "series = generate_uid()\n"
      "order = list(range(n))\n"
      "random.Random(3).shuffle(order)\n"
      "for name, k in enumerate(order):\n"
      "    d = copy.deepcopy(src)  # a shallow copy shares (and would change) src's elements\n"
      "    d.ImageOrientationPatient = [DS(float(v), auto_format=True) for v in iop]\n"
      "    p = base + steps[k] * normal + k * " +
      std::to_string(shift_mm) +
      " * row\n"
      "    d.ImagePositionPatient = [DS(float(v), auto_format=True) for v in p]\n"
      "    d.InstanceNumber = random.Random(k).randint(1, 999)\n"
      "    d.SOPInstanceUID = generate_uid()\n"
      "    d.SeriesInstanceUID = generate_uid() if " +
      (second_series ? "k == 1" : "False") +
      " else series\n"
      "    d.PixelData = (src.pixel_array + 100 * k).astype(np.int16).tobytes()\n"
      "    d.save_as('" +
      dir +
      "/slice_%03d.dcm' % name)\n"
      "open('" +
      dir + "/README.txt', 'w').write('not DICOM')\n";
  write_file(dir + "/make.py", script);
  ASSERT_EQ(std::system(("/usr/bin/python3 " + dir + "/make.py").c_str()), 0);
  std::filesystem::remove(dir + "/make.py");
}

TEST(VolumeIoDicomRealData, PydicomsCtAndMrSlicesOpenWithTheirGeometry) {
  ASSERT_TRUE(std::filesystem::exists(kPydicomFiles + "CT_small.dcm"))
      << "Debian's python3-pydicom is missing: scripts/setup.sh installs it";
  const io::RawVolume ct = io::read_dicom(kPydicomFiles + "CT_small.dcm");
  EXPECT_EQ(ct.dims, Vec3i(128, 128, 1));
  EXPECT_TRUE(ct.spacing_mm.isApprox(Vec3d(0.661468, 0.661468, 5.0), 1e-12));
  EXPECT_TRUE(ct.origin_mm.isApprox(Vec3d(-158.135803, -179.035797, -75.699997), 1e-12));
  EXPECT_EQ(ct.direction, Mat3d::Identity());
  // Rescale slope 1, intercept -1024: stored 175, 180, 166 are these Hounsfield units.
  EXPECT_EQ(ct.intensity[0], 175.0f - 1024.0f);
  EXPECT_EQ(ct.intensity[1], 180.0f - 1024.0f);
  EXPECT_EQ(ct.intensity[2], 166.0f - 1024.0f);
  EXPECT_EQ(ct.min_intensity, 128.0 - 1024.0);
  EXPECT_EQ(ct.max_intensity, 2191.0 - 1024.0);
  const io::RawVolume mr = io::read_dicom(kPydicomFiles + "MR_small.dcm");
  EXPECT_EQ(mr.dims, Vec3i(64, 64, 1));
  EXPECT_TRUE(mr.spacing_mm.isApprox(Vec3d(0.3125, 0.3125, 0.8), 1e-12));
  EXPECT_EQ(mr.intensity[0], 905.0f);  // no rescale in an MR
  // Through the format table: a .dcm file, and (below) a folder.
  EXPECT_EQ(load_volume(kPydicomFiles + "MR_small.dcm", {}).dims(), Vec3i(64, 64, 1));
}

TEST(VolumeIoDicom, SeriesSortsByPositionAlongTheNormal) {
  const std::string dir = scratch_dir();
  // Oblique: rows 30 degrees off x in the axial plane, tilted 10 degrees up.
  const double c = std::cos(std::numbers::pi / 6), s = std::sin(std::numbers::pi / 6);
  const Vec3d row(c, s, 0.0);
  const Vec3d col = Vec3d(-s, c, 0.0) * std::cos(0.1745329) + Vec3d(0, 0, 1) * std::sin(0.1745329);
  char iop[256];
  std::snprintf(iop, sizeof iop, "%.17g, %.17g, %.17g, %.17g, %.17g, %.17g", row.x(), row.y(),
                row.z(), col.x(), col.y(), col.z());
  write_series(dir, 5, iop, 2.5, 0.0);
  const io::RawVolume v = io::read_dicom(dir);
  EXPECT_EQ(v.dims, Vec3i(128, 128, 5));
  EXPECT_NEAR(v.spacing_mm.z(), 2.5, 1e-9);
  EXPECT_TRUE(v.direction.col(0).isApprox(row, 1e-9));
  EXPECT_TRUE(v.direction.col(1).isApprox(col, 1e-9));
  EXPECT_TRUE(v.direction.col(2).isApprox(row.cross(col), 1e-9));
  EXPECT_TRUE(v.origin_mm.isApprox(Vec3d(-158.135803, -179.035797, -75.699997), 1e-9));
  // Slice k carries CT_small + 100 k: in position order whatever the file names say.
  for (int k = 0; k < 5; ++k) {
    EXPECT_EQ(v.intensity[static_cast<std::size_t>(k) * 128 * 128], 175.0f - 1024.0f + 100.0f * k)
        << "slice " << k;
  }
  // The folder loads as a volume through the table.
  EXPECT_EQ(load_volume(dir, {}).dims(), Vec3i(128, 128, 5));
}

TEST(VolumeIoDicomErrors, TiltGapsDuplicatesAndMixedSeriesAreRefused) {
  const std::string axial = "1, 0, 0, 0, 1, 0";
  const std::string root = scratch_dir();
  auto fresh = [&](const std::string& name) {
    const std::string dir = root + "/" + name;
    std::filesystem::create_directories(dir);
    return dir;
  };
  const std::string tilt = fresh("tilt");
  write_series(tilt, 4, axial, 2.0, 0.5);
  expect_input_error([&] { io::read_dicom(tilt); }, tilt, "gantry tilt: the slices step 14");
  const std::string gaps = fresh("gaps");
  write_series(gaps, 4, axial, 0.0, 0.0, "0.0, 2.0, 4.0, 7.0");
  expect_input_error([&] { io::read_dicom(gaps); }, gaps,
                     "non-uniform slice spacing (2 mm to 3 mm)");
  const std::string twice = fresh("twice");
  write_series(twice, 3, axial, 0.0, 0.0, "0.0, 2.0, 2.0");
  expect_input_error([&] { io::read_dicom(twice); }, twice, "two slices at one position");
  const std::string mixed = fresh("mixed");
  write_series(mixed, 3, axial, 2.0, 0.0, "", /*second_series=*/true);
  expect_input_error([&] { io::read_dicom(mixed); }, mixed, "holds more than one series");
  const std::string empty = fresh("empty");
  write_file(empty + "/notes.txt", "no images here");
  expect_input_error([&] { io::read_dicom(empty); }, empty, "no DICOM file");
  expect_input_error([&] { io::read_dicom(root + "/none"); }, root + "/none",
                     "cannot open file or folder");
}

}  // namespace
}  // namespace hapvox::engine

namespace hapvox::engine {
namespace {

// A DICOM file cut short, as a failed copy or download leaves it, is one line naming it,
// never a crash (GDCM asserts on most cuts: its child process takes the abort) and never a
// volume (GDCM reads a cut inside the pixels as zeros and only warns).
TEST(VolumeIoDicomErrors, TruncatedFilesAreOneLineErrorsNotCrashesOrZeros) {
  const std::string dir = scratch_dir();
  const std::string ct = testing::read_file(kPydicomFiles + "CT_small.dcm");
  ASSERT_EQ(ct.size(), 39206u);
  const std::string crashed =
      "GDCM crashed reading it (signal 6, Aborted): a corrupt or truncated file";
  const std::string cut_pixels = "its pixel data ends early (a truncated file)";
  // Where GDCM asserts: inside the meta header (132, 200), a sequence (1000), the last byte
  // of the pixels (39205).
  for (const auto& [bytes, problem] :
       std::vector<std::pair<std::size_t, std::string>>{{132, crashed},
                                                        {200, crashed},
                                                        {1000, crashed},
                                                        {10000, cut_pixels},
                                                        {39000, cut_pixels},
                                                        {39205, crashed}}) {
    const std::string file = dir + "/cut_" + std::to_string(bytes) + ".dcm";
    write_file(file, ct.substr(0, bytes));
    EXPECT_EQ(testing::input_error_of([&] { io::read_dicom(file); }), file + ": " + problem);
  }
  // In a series folder, the file whose pixels are cut is named.
  std::filesystem::create_directories(dir + "/series");
  write_file(dir + "/series/README.txt", "not DICOM: skipped\n");
  write_file(dir + "/series/b.dcm", ct.substr(0, 39000));
  EXPECT_EQ(testing::input_error_of([&] { io::read_dicom(dir + "/series"); }),
            dir + "/series/b.dcm: " + cut_pixels);
  // The whole file still reads, through the same child process.
  write_file(dir + "/whole.dcm", ct);
  EXPECT_EQ(io::read_dicom(dir + "/whole.dcm").dims, Vec3i(128, 128, 1));
}

}  // namespace
}  // namespace hapvox::engine
