// hapvox convert: every writer from the command line, the world box as an independent reader
// sees it (nibabel for NIfTI, a few lines of Python reading the MetaImage header), and bad
// input.

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "test_data.h"

namespace hapvox {
namespace {

namespace fs = std::filesystem;
using testing::run_hapvox;
using testing::scratch_dir;
using testing::source_path;

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// The numbers after "world box (LPS)" in hapvox convert's output: xmin xmax ymin ymax zmin zmax.
std::vector<double> world_box_of(const std::string& out) {
  const auto at = out.find("world box (LPS)");
  std::vector<double> v(6);
  if (at == std::string::npos ||
      std::sscanf(out.c_str() + at, "world box (LPS) [%lf, %lf] x [%lf, %lf] x [%lf, %lf]", &v[0],
                  &v[1], &v[2], &v[3], &v[4], &v[5]) != 6) {
    return {};
  }
  return v;
}

std::vector<double> numbers_of(const std::string& line) {
  std::istringstream in(line);
  std::vector<double> v;
  for (double x; in >> x;) v.push_back(x);
  return v;
}

// The number after "total density" (convert and info both print one).
double total_density_of(const std::string& out) {
  const auto at = out.find("total density");
  return at == std::string::npos ? -1.0 : std::strtod(out.c_str() + at + 13, nullptr);
}

// hapvox prints 6 significant digits.
void expect_same_box(const std::vector<double>& a, const std::vector<double>& b,
                     const std::string& what) {
  ASSERT_EQ(a.size(), 6u) << what;
  ASSERT_EQ(b.size(), 6u) << what;
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(a[i], b[i], 1e-3) << what << " " << i;
}

// A small oblique CT in RAS: a NRRD written by hand, turned 30 degrees about z, tilted.
std::string oblique_nrrd(const std::string& dir) {
  const std::string path = dir + "/oblique.nrrd";
  std::string samples;
  for (int i = 0; i < 4 * 3 * 2; ++i) samples.push_back(static_cast<char>(i * 10));
  write_text(path,
             "NRRD0004\ntype: uint8\ndimension: 3\nspace: right-anterior-superior\n"
             "sizes: 4 3 2\nspace directions: (0.8660254037844387,0.5,0) "
             "(-1,1.7320508075688772,0) (0,0,2.5)\nspace origin: (-10,5,40)\n"
             "encoding: raw\n\n" +
                 samples);
  return path;
}

TEST(HapvoxConvert, NiftiAndMetaImageShowTheSameWorldBoxToIndependentReaders) {
  if (std::system("/usr/bin/python3 -c 'import nibabel' 2>/dev/null") != 0) {
    FAIL() << "python3-nibabel is not installed (scripts/setup.sh installs it)";
  }
  const std::string dir = scratch_dir();
  const std::string in = oblique_nrrd(dir);
  const auto nii = run_hapvox("convert " + in + " " + dir + "/oblique.nii.gz --threshold 1");
  ASSERT_EQ(nii.exit_code, 0) << nii.err;
  const auto mha = run_hapvox("convert " + dir + "/oblique.nii.gz " + dir + "/oblique.mha");
  ASSERT_EQ(mha.exit_code, 0) << mha.err;
  const std::vector<double> hapvox_box = world_box_of(nii.out);
  ASSERT_EQ(hapvox_box.size(), 6u) << nii.out;
  expect_same_box(world_box_of(mha.out), hapvox_box, "hapvox, from the .nii.gz");

  // Corners of the voxel box [-0.5, n - 0.5] through each file's own affine; RAS -> LPS.
  const std::string script =
      "import sys, itertools, numpy as np, nibabel as nib\n"
      "def box(corners):\n"
      "    c = np.array(corners)\n"
      "    return ' '.join('%.6f %.6f' % (c[:, a].min(), c[:, a].max()) for a in range(3))\n"
      "img = nib.load(sys.argv[1])\n"
      "n = img.shape\n"
      "ras = [img.affine @ np.array([i, j, k, 1.0]) for i, j, k in\n"
      "       itertools.product(*[(-0.5, s - 0.5) for s in n])]\n"
      "print(box([[-p[0], -p[1], p[2]] for p in ras]))\n"
      "h = dict(l.split(' = ', 1) for l in open(sys.argv[2], "
      "'rb').read().split(b'ElementDataFile')[0]"
      ".decode().strip().splitlines())\n"
      "m = np.array(h['TransformMatrix'].split(), float).reshape(3, 3)  # row a: axis a\n"
      "s = np.array(h['ElementSpacing'].split(), float)\n"
      "o = np.array(h['Offset'].split(), float)\n"
      "d = np.array(h['DimSize'].split(), int)\n"
      "print(box([o + (np.array(ijk) * s) @ m for ijk in\n"
      "           itertools.product(*[(-0.5, s - 0.5) for s in d])]))\n";
  write_text(dir + "/box.py", script);
  const std::string out_path = dir + "/box.txt";
  ASSERT_EQ(std::system(("/usr/bin/python3 " + dir + "/box.py " + dir + "/oblique.nii.gz " + dir +
                         "/oblique.mha > " + out_path)
                            .c_str()),
            0);
  std::ifstream boxes(out_path);
  std::string nibabel_line, metaimage_line;
  std::getline(boxes, nibabel_line);
  std::getline(boxes, metaimage_line);
  expect_same_box(numbers_of(nibabel_line), hapvox_box, "nibabel");
  expect_same_box(numbers_of(metaimage_line), hapvox_box, "the MetaImage header");
}

// A label map stays a label map: integers in the smallest type, NIfTI's label intent, the
// same labels and world box to nibabel, and back to NRRD with every label as it was.
TEST(HapvoxConvert, LabelMapsConvertAsIntegers) {
  if (std::system("/usr/bin/python3 -c 'import nibabel' 2>/dev/null") != 0) {
    FAIL() << "python3-nibabel is not installed (scripts/setup.sh installs it)";
  }
  const std::string dir = scratch_dir();
  // uint16 labels 0, 3 and 1000 on the oblique grid of oblique_nrrd.
  std::string samples;
  const unsigned short values[4] = {0, 3, 1000, 3};
  for (int i = 0; i < 24; ++i) {
    samples.append(reinterpret_cast<const char*>(&values[i % 4]), 2);
  }
  const std::string in = dir + "/seg.nrrd";
  write_text(in,
             "NRRD0004\ntype: uint16\ndimension: 3\nspace: right-anterior-superior\n"
             "sizes: 4 3 2\nspace directions: (0.8660254037844387,0.5,0) "
             "(-1,1.7320508075688772,0) (0,0,2.5)\nspace origin: (-10,5,40)\n"
             "endian: little\nencoding: raw\n\n" +
                 samples);
  const auto nii = run_hapvox("convert --labels " + in + " " + dir + "/seg.nii.gz");
  ASSERT_EQ(nii.exit_code, 0) << nii.err;
  EXPECT_NE(nii.out.find("(NIfTI label map, uint16): 4 x 3 x 2 voxels, 18 labelled, 2 labels"),
            std::string::npos)
      << nii.out;
  const std::vector<double> hapvox_box = world_box_of(nii.out);
  ASSERT_EQ(hapvox_box.size(), 6u) << nii.out;

  const std::string script =
      "import sys, itertools, numpy as np, nibabel as nib\n"
      "img = nib.load(sys.argv[1])\n"
      "print(img.get_data_dtype(), img.header.get_intent()[0])\n"
      "a = np.asanyarray(img.dataobj)\n"
      "print(' '.join(str(int(v)) for v in a.flatten(order='F')))\n"
      "c = np.array([img.affine @ np.array([i, j, k, 1.0]) for i, j, k in\n"
      "       itertools.product(*[(-0.5, s - 0.5) for s in img.shape])])\n"
      "c[:, :2] *= -1\n"
      "print(' '.join('%.6f %.6f' % (c[:, a].min(), c[:, a].max()) for a in range(3)))\n";
  write_text(dir + "/labels.py", script);
  ASSERT_EQ(std::system(("/usr/bin/python3 " + dir + "/labels.py " + dir + "/seg.nii.gz > " + dir +
                         "/labels.txt")
                            .c_str()),
            0);
  std::ifstream seen(dir + "/labels.txt");
  std::string type_line, values_line, box_line;
  std::getline(seen, type_line);
  std::getline(seen, values_line);
  std::getline(seen, box_line);
  EXPECT_EQ(type_line, "uint16 label");
  std::string expected_values;
  for (int i = 0; i < 24; ++i) {
    expected_values += (i ? " " : "") + std::to_string(values[i % 4]);
  }
  EXPECT_EQ(values_line, expected_values);
  expect_same_box(numbers_of(box_line), hapvox_box, "nibabel");

  // Back to NRRD: the same uint16 samples, in the same order.
  const auto back = run_hapvox("convert --labels " + dir + "/seg.nii.gz " + dir + "/back.nrrd");
  ASSERT_EQ(back.exit_code, 0) << back.err;
  expect_same_box(world_box_of(back.out), hapvox_box, "hapvox, from the .nii.gz");
  const auto info = run_hapvox("info " + dir + "/back.nrrd");
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(
      info.out.find("back.nrrd: NRRD volume, uint16 label map\n  labels           0 .. 1000\n"),
      std::string::npos)
      << info.out;

  // A density is no label: one line naming the voxel, nothing written.
  std::string floats(6 * sizeof(float), '\0');
  const float half = 0.5f;
  std::memcpy(floats.data() + 5 * sizeof(float), &half, sizeof half);
  write_text(dir + "/density.nrrd",
             "NRRD0004\ntype: float\ndimension: 3\nsizes: 3 2 1\nendian: little\n"
             "encoding: raw\n\n" +
                 floats);
  const auto density = run_hapvox("convert --labels " + dir + "/density.nrrd " + dir + "/d.nrrd");
  EXPECT_EQ(density.exit_code, 2);
  EXPECT_EQ(density.err, "hapvox: error: " + dir +
                             "/density.nrrd: voxel (2, 1, 0) holds 0.5, not a label (an integer "
                             "in [0, 16777216])\n");
  EXPECT_FALSE(fs::exists(dir + "/d.nrrd"));
}

TEST(HapvoxConvert, EveryFormatRoundTripsTheBundledCt) {
  const std::string dir = scratch_dir();
  const std::string ct = source_path("data/headsq_64x64x93_uint16.nrrd");
  const auto first = run_hapvox("convert " + ct + " " + dir + "/head.vdb --threshold 700");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const std::string density_line = first.out.substr(first.out.find("total density"));
  std::string previous = dir + "/head.vdb";
  for (const std::string ext : {".nrrd", ".mha", ".mhd", ".nii", ".nii.gz", ".vdb"}) {
    const std::string next = dir + "/next" + ext;
    const auto step = run_hapvox("convert " + previous + " " + next);
    ASSERT_EQ(step.exit_code, 0) << ext << ": " << step.err;
    // Densities read back as densities: the same mass, to the printed digits, each time.
    EXPECT_EQ(step.out.substr(step.out.find("total density")), density_line) << ext;
    previous = next;
  }
  // info says what the file holds and reads it as written, whatever the mapping flags.
  const auto info = run_hapvox("info " + dir + "/next.mha --threshold 0.99");
  EXPECT_NE(info.out.find("MetaImage volume, float densities written by hapvox"), std::string::npos)
      << info.out;
  EXPECT_EQ(total_density_of(info.out), total_density_of(first.out)) << info.out;
}

// A headerless raw file, its layout given on the command line, converts into a NRRD whose
// samples, spacing and origin are the raw file's (read back by hapvox info).
TEST(HapvoxConvert, ARawFileWithItsLayoutConverts) {
  const std::string dir = scratch_dir();
  // 4 x 3 x 2 big-endian int16 samples 0, 100, 200, ... behind 3 header bytes.
  std::string bytes = "HDR";
  for (int v = 0; v < 24; ++v) {
    const int sample = 100 * v;
    bytes += static_cast<char>((sample >> 8) & 0xff);
    bytes += static_cast<char>(sample & 0xff);
  }
  write_text(dir + "/scan.raw", bytes);
  const std::string spec = dir +
                           "/scan.raw:dims=4x3x2,type=int16,endian=big,spacing_mm=0.5x2x3,"
                           "origin_mm=-1x0x7,header_bytes=3";
  const auto info = run_hapvox("info " + spec);
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("raw volume"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("4 x 3 x 2"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("int16"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("0 .. 2300"), std::string::npos) << info.out;
  const auto converted = run_hapvox("convert " + spec + " " + dir + "/scan.nrrd --threshold 1150");
  ASSERT_EQ(converted.exit_code, 0) << converted.err;
  // The world box: origin -1,0,7 and spacing 0.5,2,3, voxel faces half a spacing out.
  EXPECT_EQ(world_box_of(converted.out), (std::vector<double>{-1.25, 0.75, -1.0, 5.0, 5.5, 11.5}))
      << converted.out;
  // Samples >= 1150 (v >= 12: the upper slice) are solid: 12 voxels.
  EXPECT_NE(converted.out.find("total density 12"), std::string::npos) << converted.out;
  const auto wrong = run_hapvox("info " + dir + "/scan.raw:dims=4x3x2,type=int16");
  EXPECT_EQ(wrong.exit_code, 2);
  EXPECT_EQ(wrong.err, "hapvox: error: " + dir +
                           "/scan.raw: holds 51 bytes, but 4x3x2 samples of int16 after 0 header "
                           "bytes need 48\n");
}

TEST(HapvoxConvert, BadOutputsAreRefusedBeforeWriting) {
  const std::string dir = scratch_dir();
  const std::string in = oblique_nrrd(dir);
  const auto unknown = run_hapvox("convert " + in + " " + dir + "/x.png");
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.err.find("x.png: unknown output format (expected .nrrd, .nhdr, .vdb"),
            std::string::npos)
      << unknown.err;
  const auto onto = run_hapvox("convert " + in + " " + in);
  EXPECT_EQ(onto.exit_code, 2);
  EXPECT_NE(onto.err.find("would overwrite the input volume"), std::string::npos) << onto.err;
  // A .mhd's data file is written beside it: it must not land on an input's data either.
  ASSERT_EQ(run_hapvox("convert " + in + " " + dir + "/b.mhd").exit_code, 0);
  fs::rename(dir + "/b.mhd", dir + "/a.mhd");  // a header naming b.zraw
  const std::string data_before = testing::read_file(dir + "/b.zraw");
  const auto clash = run_hapvox("convert " + dir + "/a.mhd " + dir + "/b.mhd");
  EXPECT_EQ(clash.exit_code, 2);
  EXPECT_NE(clash.err.find("would overwrite the input volume data file"), std::string::npos)
      << clash.err;
  EXPECT_EQ(testing::read_file(dir + "/b.zraw"), data_before);
  const auto missing = run_hapvox("convert " + dir + "/none.nii.gz " + dir + "/y.nrrd");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("none.nii.gz: cannot open file"), std::string::npos) << missing.err;
  EXPECT_FALSE(fs::exists(dir + "/y.nrrd"));
}

}  // namespace
}  // namespace hapvox
