// `hapvox replay --materials` with the voxel model end to end: a CT-like slab of two
// intensities becomes two tissues through the materials file's intensity ranges, and the
// same press on each gives forces in the ratio of their moduli; bad combinations of flags
// are one line and exit 2.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "haptics/session.h"
#include "test_data.h"

namespace hapvox {
namespace {

namespace fs = std::filesystem;
using testing::run_hapvox;
using testing::scratch_dir;

constexpr int kN = 48;  // 48^3 voxels of 1 mm; material fills z < 24 (surface z = 23.5 mm)

// Raw samples 100 (x < 24) and 200 (x >= 24) under z = 24, 0 above: a slab of two tissues.
std::string write_slab(const std::string& dir) {
  std::string payload(static_cast<std::size_t>(kN) * kN * kN, '\0');
  for (int k = 0; k < kN / 2; ++k)
    for (int j = 0; j < kN; ++j)
      for (int i = 0; i < kN; ++i)
        payload[(static_cast<std::size_t>(k) * kN + j) * kN + i] = char(i < kN / 2 ? 100 : 200);
  const std::string path = dir + "/slab.nrrd";
  std::ofstream out(path, std::ios::binary);
  out << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 48 48 48\nspacings: 1 1 1\n"
         "endian: little\nencoding: raw\n\n"
      << payload;
  return path;
}

std::string write_materials(const std::string& dir) {
  const std::string path = dir + "/slab.toml";
  std::ofstream(path) << "[[material]]\nlabel = 1\nname = \"fat\"\nyoungs_modulus_pa = 100e3\n"
                         "poisson_ratio = 0.3\nintensity = [50, 150]\n\n"
                         "[[material]]\nlabel = 2\nname = \"muscle\"\nyoungs_modulus_pa = 400e3\n"
                         "poisson_ratio = 0.3\nintensity = [151, 255]\n";
  return path;
}

// The 8 mm tool from 1 mm above the surface at (x, 24.2) down 1 mm into it over 0.2 s, held.
std::string write_press(const std::string& dir, const std::string& name, double x_mm) {
  const std::string path = dir + "/" + name;
  std::ofstream out(path);
  out << "t,x,y,z\n";
  for (int k = 0; k <= 300; ++k) {
    const double d = -1.0 + 2.0 * std::min(1.0, k / 200.0);
    out << k / 1000.0 << "," << x_mm << ",24.2," << 23.5 + 4.0 - d << "\n";
  }
  return path;
}

double final_force_z(const std::string& session) {
  const std::vector<double> force = haptics::read_session_column(session, "/force_n");
  return force.at(force.size() - 1);
}

TEST(ReplayTissueCli, TheSamePressOnTwoTissuesGivesTheRatioOfTheirModuli) {
  const std::string dir = scratch_dir();
  const std::string slab = write_slab(dir);
  const std::string materials = write_materials(dir);
  double force_z[2] = {0, 0};
  const double x_mm[2] = {11.7, 35.7};
  for (int side = 0; side < 2; ++side) {
    const std::string trace = write_press(dir, "press" + std::to_string(side) + ".csv", x_mm[side]);
    const std::string session = dir + "/s" + std::to_string(side) + ".h5";
    const auto r = run_hapvox("replay " + trace + " --volume " + slab + " --materials " +
                              materials + " -q -o " + session);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    force_z[side] = final_force_z(session);
    // The session names the file and the table it made.
    const haptics::SessionInfo info = haptics::read_session_info(session);
    std::string tissues, recorded;
    for (const auto& [name, value] : info.attributes) {
      if (name == "tissues") tissues = value;
      if (name == "materials") recorded = value;
    }
    EXPECT_EQ(recorded, materials);
    EXPECT_NE(tissues.find("fat: E 100000 Pa, nu 0.3"), std::string::npos) << tissues;
    EXPECT_NE(tissues.find("; muscle: E 400000 Pa, nu 0.3"), std::string::npos) << tissues;
    EXPECT_EQ(tissues.find('\n'), std::string::npos) << tissues;  // one line for `info`
  }
  ASSERT_GT(force_z[0], 0.05);
  EXPECT_NEAR(force_z[1] / force_z[0], 4.0, 1e-5);
  // Without --materials the slab is one material (the command's E): both sides alike.
  const std::string plain = dir + "/plain.h5";
  ASSERT_EQ(run_hapvox("replay " + dir + "/press1.csv --volume " + slab + " --threshold 50 -q -o " +
                       plain)
                .exit_code,
            0);
  const std::string plain0 = dir + "/plain0.h5";
  ASSERT_EQ(run_hapvox("replay " + dir + "/press0.csv --volume " + slab + " --threshold 50 -q -o " +
                       plain0)
                .exit_code,
            0);
  EXPECT_NEAR(final_force_z(plain) / final_force_z(plain0), 1.0, 1e-5);
}

TEST(ReplayTissueCli, FlagsThatDoNotFitAreOneLine) {
  const std::string dir = scratch_dir();
  const std::string slab = write_slab(dir);
  const std::string materials = write_materials(dir);
  const std::string trace = write_press(dir, "press.csv", 11.7);
  const std::string base = "replay " + trace + " --volume " + slab + " -q -o " + dir + "/bad.h5";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {" --materials " + materials + " --threshold 50",
       "hapvox: error: --threshold: is not used with --materials (the materials file gives each "
       "tissue its density)\n"},
      {" --labels " + slab, "hapvox: error: --labels: needs --materials\n"},
      {" --seed 10,10,10", "hapvox: error: --seed: needs --materials\n"},
      {" --materials " + materials + " --spacing-mm 4",
       "hapvox: error: --spacing-mm: needs --model fem\n"},
      {" --materials " + dir + "/none.toml",
       "hapvox: error: " + dir + "/none.toml: cannot open file\n"},
  };
  // The same slab turned a quarter about z: labels are made on the index grid, so a turned
  // scan is refused rather than given tissues in the wrong places.
  std::string turned = testing::read_file(slab);
  const std::string plain_spacing = "spacings: 1 1 1\n";
  turned.replace(turned.find(plain_spacing), plain_spacing.size(),
                 "space: left-posterior-superior\nspace directions: (0,1,0) (-1,0,0) (0,0,1)\n");
  std::ofstream(dir + "/turned.nrrd", std::ios::binary) << turned;
  const auto r = run_hapvox("replay " + trace + " --volume " + dir + "/turned.nrrd -q -o " + dir +
                            "/bad.h5 --materials " + materials);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "hapvox: error: " + dir +
                       "/turned.nrrd: materials by tissue need a volume whose index axes are "
                       "world x, y, z (this one's direction cosines are not the identity)\n");
  EXPECT_FALSE(fs::exists(dir + "/bad.h5"));
  for (const auto& [args, message] : cases) {
    const auto r = run_hapvox(base + args);
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_EQ(r.err, message) << args;
    EXPECT_FALSE(fs::exists(dir + "/bad.h5")) << args;
  }
}

}  // namespace
}  // namespace hapvox
