// `hapvox mesh` end to end: the proxy mesh written with its XDMF file and a report that
// matches the file; one-line errors (exit 2) for each kind of bad input, nothing written.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>

#include "engine/fem/tet_mesh.h"
#include "engine/io/formats.h"
#include "engine/labels/four_spheres.h"
#include "haptics/mesh_file.h"
#include "haptics/session.h"
#include "render/camera.h"
#include "test_data.h"

namespace hapvox {
namespace {

namespace fs = std::filesystem;
using testing::run_hapvox;
using testing::scratch_dir;
using testing::source_path;

const char* const kMeshPhantom = "four-spheres:dims=24";

std::string four_spheres_toml() { return source_path("data/four_spheres.toml"); }

// One [[material]] table per label in `labels`, with E and nu as given.
std::string materials_text(const std::vector<int>& labels, const std::string& youngs = "1e6",
                           const std::string& poisson = "0.45") {
  std::string text;
  for (int label : labels) {
    text += "[[material]]\nlabel = " + std::to_string(label) + "\nyoungs_modulus_pa = " + youngs +
            "\npoisson_ratio = " + poisson + "\n";
  }
  return text;
}

std::string write(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// A bad-input run: exit 2, exactly one line on stderr, equal to `expected`, and no mesh.
void expect_mesh_error(const std::string& dir, const std::string& args,
                       const std::string& expected) {
  const auto r = run_hapvox("mesh " + args);
  EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err;
  EXPECT_EQ(r.err, "hapvox: error: " + expected + "\n") << args;
  EXPECT_FALSE(fs::exists(dir + "/out.h5")) << args;
  EXPECT_FALSE(fs::exists(dir + "/out.h5.partial")) << args;
  EXPECT_FALSE(fs::exists(dir + "/out.xdmf")) << args;
}

// The integer printed after `label` on a line of the report.
long printed(const std::string& out, const std::string& label) {
  std::smatch m;
  if (!std::regex_search(out, m, std::regex(label + " +([0-9]+)"))) return -1;
  return std::stol(m[1]);
}

TEST(MeshCli, BuildsTheFourSpheresMeshAndReportsWhatItWrote) {
  const std::string dir = scratch_dir();
  const std::string mesh = dir + "/phantom.h5";
  const auto r = run_hapvox(std::string("mesh ") + kMeshPhantom + " --materials " +
                            four_spheres_toml() + " -o " + mesh + " --spacing-mm 4.32");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  std::printf("%s", r.out.c_str());
  ASSERT_TRUE(fs::exists(mesh));
  ASSERT_TRUE(fs::exists(dir + "/phantom.xdmf"));
  EXPECT_FALSE(fs::exists(mesh + ".partial"));

  const long vertices = printed(r.out, "vertices");
  const long tets = printed(r.out, "tets");
  const std::vector<double> classes = haptics::read_session_column(mesh, "/mesh/vertex_class");
  const std::vector<double> labels = haptics::read_session_column(mesh, "/mesh/tet_label");
  EXPECT_EQ(vertices, static_cast<long>(classes.size()));
  EXPECT_EQ(tets, static_cast<long>(labels.size()));
  EXPECT_EQ(haptics::read_session_column(mesh, "/mesh/rest_mm").size(), 3u * vertices);
  const long fixed = std::count(classes.begin(), classes.end(), 2.0);
  EXPECT_GT(fixed, 0);
  EXPECT_NE(r.out.find("(" + std::to_string(fixed) + " fixed)"), std::string::npos) << r.out;
  for (int label = 0; label <= 4; ++label) {
    EXPECT_NE(r.out.find("label " + std::to_string(label) + " "), std::string::npos) << r.out;
  }
  EXPECT_NE(r.out.find("dihedral angles"), std::string::npos);
  EXPECT_NE(r.out.find("build time"), std::string::npos);
  EXPECT_NE(r.out.find("wrote " + mesh + " and " + dir + "/phantom.xdmf"), std::string::npos);

  // `hapvox info` describes the file with the same counts.
  const auto info = run_hapvox("info " + mesh);
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("hapvox proxy mesh"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find(std::to_string(vertices) + " vertices (" + std::to_string(fixed) +
                          " fixed), " + std::to_string(tets) + " tets"),
            std::string::npos)
      << info.out;
  EXPECT_NE(info.out.find("E 1e+08 Pa, nu 0.45"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find(four_spheres_toml()), std::string::npos) << info.out;
}

TEST(MeshCli, SeedsMakeTheLabels) {
  const std::string dir = scratch_dir();
  const testing::FourSpheres phantom{24, 1.0};
  const engine::Vec3d c = phantom.centre_mm(1);
  const std::string materials = write(dir + "/m.toml", materials_text({0, 5}));
  // The volume after the seeds: each --seed takes one value.
  const auto r = run_hapvox("mesh --materials " + materials + " --seed " + std::to_string(c.x()) +
                            "," + std::to_string(c.y()) + "," + std::to_string(c.z()) +
                            ":5 --seed-tolerance 0.05 " + kMeshPhantom + " -o " + dir + "/out.h5");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::vector<double> labels =
      haptics::read_session_column(dir + "/out.h5", "/mesh/tet_label");
  EXPECT_EQ(std::set<double>(labels.begin(), labels.end()), (std::set<double>{0, 5}));
}

// --labels-out writes the grown label map as integers: the seeded sphere is label 5, the
// others background, and meshing that file with --labels gives the seeds' mesh again.
TEST(MeshCli, TheSeededLabelMapIsWrittenAndMeshesTheSame) {
  const std::string dir = scratch_dir();
  const testing::FourSpheres phantom{24, 1.0};
  const engine::Vec3d c = phantom.centre_mm(1);
  const std::string materials = write(dir + "/m.toml", materials_text({0, 5}));
  const std::string seed = std::to_string(c.x()) + "," + std::to_string(c.y()) + "," +
                           std::to_string(c.z()) + ":5 --seed-tolerance 0.05 ";
  const auto r = run_hapvox("mesh --materials " + materials + " --seed " + seed + kMeshPhantom +
                            " -o " + dir + "/seeded.h5 --labels-out " + dir + "/seg.nii.gz");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("wrote " + dir + "/seg.nii.gz (the label map the mesh was built from)"),
            std::string::npos)
      << r.out;
  const engine::RawVolume seg = engine::io::read_scalar_volume(dir + "/seg.nii.gz");
  EXPECT_EQ(seg.sample_type, "uint8");
  EXPECT_EQ(seg.dims, engine::Vec3i(24, 24, 24));
  EXPECT_EQ(std::set<float>(seg.intensity.begin(), seg.intensity.end()), (std::set<float>{0, 5}));
  const auto at = [&](const engine::Vec3d& p_mm) {
    const engine::Vec3d i = (p_mm - seg.origin_mm).cwiseQuotient(seg.spacing_mm);
    const engine::Vec3i v(static_cast<int>(std::lround(i.x())),
                          static_cast<int>(std::lround(i.y())),
                          static_cast<int>(std::lround(i.z())));
    return seg.intensity[static_cast<std::size_t>(v.x() + 24 * (v.y() + 24 * v.z()))];
  };
  EXPECT_EQ(at(c), 5.0f);
  for (int sphere : {2, 3, 4}) EXPECT_EQ(at(phantom.centre_mm(sphere)), 0.0f) << sphere;

  const auto again = run_hapvox("mesh --materials " + materials + " --labels " + dir +
                                "/seg.nii.gz " + kMeshPhantom + " -o " + dir + "/from_file.h5");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_EQ(haptics::read_session_column(dir + "/from_file.h5", "/mesh/tet_label"),
            haptics::read_session_column(dir + "/seeded.h5", "/mesh/tet_label"));
  EXPECT_EQ(haptics::read_session_column(dir + "/from_file.h5", "/mesh/rest_mm"),
            haptics::read_session_column(dir + "/seeded.h5", "/mesh/rest_mm"));

  // An output it cannot write is refused before anything is meshed or written.
  const auto bad = run_hapvox("mesh --materials " + materials + " --seed " + seed + kMeshPhantom +
                              " -o " + dir + "/bad.h5 --labels-out " + dir + "/seg.hdr");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_EQ(bad.err, "hapvox: error: " + dir +
                         "/seg.hdr: unknown output format (expected .nrrd, .nhdr, .vdb, .mha, "
                         ".mhd, .nii or .nii.gz)\n");
  EXPECT_FALSE(fs::exists(dir + "/bad.h5"));
}

// Picking (Nakao §3.2): the pixel where `hapvox render` shows the sphere nearest the camera
// seeds that sphere's region: label 5's tets fill it (centroid and volume), no other.
TEST(MeshCli, APickedPixelSeedsTheSphereTheImageShowsThere) {
  const std::string dir = scratch_dir();
  const testing::FourSpheres phantom{24, 1.0};
  const render::OrbitCamera camera = render::OrbitCamera::framing(
      engine::Vec3d::Constant(-0.5), engine::Vec3d::Constant(23.5), 30.0, 25.0);
  int nearest = 0;
  for (int s = 1; s < 4; ++s) {
    if ((phantom.centre_mm(s) - camera.eye_mm()).norm() <
        (phantom.centre_mm(nearest) - camera.eye_mm()).norm()) {
      nearest = s;
    }
  }
  const int size = 256;
  const Eigen::Vector4d clip =
      camera.projection(1.0, 1.0, 1e4) * camera.view() * phantom.centre_mm(nearest).homogeneous();
  const int px = static_cast<int>(0.5 * (clip.x() / clip.w() + 1.0) * size);
  const int py = static_cast<int>(0.5 * (1.0 - clip.y() / clip.w()) * size);
  const std::string materials = write(dir + "/m.toml", materials_text({0, 5}));
  const auto r = run_hapvox("mesh " + std::string(kMeshPhantom) + " --materials " + materials +
                            " --pick " + std::to_string(px) + "," + std::to_string(py) +
                            ":5 --pick-size 256 --pick-view 30,25 --seed-tolerance 0.05 -o " + dir +
                            "/out.h5");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const engine::fem::TetMesh mesh = haptics::read_tet_mesh(dir + "/out.h5");
  double volume = 0.0;
  engine::Vec3d moment = engine::Vec3d::Zero();
  for (int t = 0; t < mesh.tet_count(); ++t) {
    if (mesh.labels[static_cast<std::size_t>(t)] != 5) continue;
    const auto& tet = mesh.tets[static_cast<std::size_t>(t)];
    const double v =
        engine::fem::signed_volume_mm3(mesh.rest_mm.col(tet[0]), mesh.rest_mm.col(tet[1]),
                                       mesh.rest_mm.col(tet[2]), mesh.rest_mm.col(tet[3]));
    volume += v;
    for (int a = 0; a < 4; ++a)
      moment += 0.25 * v * mesh.rest_mm.col(tet[static_cast<std::size_t>(a)]);
  }
  ASSERT_GT(volume, 0.0) << "nothing got label 5";
  EXPECT_LT((moment / volume - phantom.centre_mm(nearest)).norm(), 0.5)
      << "picked sphere " << nearest << " at pixel " << px << "," << py;
  EXPECT_NEAR(volume, static_cast<double>(phantom.lattice_count(nearest)),
              0.05 * static_cast<double>(phantom.lattice_count(nearest)));

  const std::string base =
      std::string(kMeshPhantom) + " --materials " + materials + " -o " + dir + "/out2.h5";
  const auto expect_pick_error = [&](const std::string& args, const std::string& expected) {
    const auto bad = run_hapvox("mesh " + base + args);
    EXPECT_EQ(bad.exit_code, 2) << args << "\n" << bad.err;
    EXPECT_EQ(bad.err, "hapvox: error: " + expected + "\n") << args;
    EXPECT_FALSE(fs::exists(dir + "/out2.h5")) << args;
  };
  expect_pick_error(" --pick 0,0",
                    "--pick: pixel 0,0 sees nothing: the accumulated opacity along its ray stays "
                    "below 0.5");
  expect_pick_error(" --pick 10", "--pick: expected PX,PY[:LABEL], got '10'");
  expect_pick_error(" --pick 10,x",
                    "--pick: expected PX,PY[:LABEL] with integer pixels, got '10,x'");
  expect_pick_error(" --pick 600,3",
                    "--pick: pixel '600,3' is outside the 512x512 image (--pick-size)");
  expect_pick_error(" --pick 3,3:0", "--pick: label in '3,3:0' must lie in [1, 16777216]");
  expect_pick_error(" --pick 3,3 --pick-threshold 1",
                    "--pick-threshold: must lie in (0, 1), not 1");
  expect_pick_error(" --pick 3,3 --pick-view 30",
                    "--pick-view: expected AZIMUTH,ELEVATION in degrees, got '30'");
}

// The optional comparison with TetGen (Debian's program, run, never linked): it meshes the
// surface and label boundaries hapvox's mesh exports (-Y: kept as they are), so every label
// keeps its volume: a wrong surface (a face left out, a label boundary missed) or a tet
// labelled from the wrong proxy tet changes a label's volume.
TEST(MeshCli, TetgenMeshesTheExportedLabelBoundariesAndEveryLabelKeepsItsVolume) {
  const std::string dir = scratch_dir();
  const auto r = run_hapvox("mesh " + std::string(kMeshPhantom) + " --materials " +
                            four_spheres_toml() + " --boundary-levels 1 -o " + dir +
                            "/m.h5 --tetgen-out " + dir + "/m --tetgen tetgen");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const char* file : {"m.node", "m.ele", "m.smesh", "m.1.node", "m.1.ele"}) {
    EXPECT_TRUE(fs::exists(dir + "/" + file)) << file;
  }
  // "  label N   hapvox_volume   tetgen_volume mm^3", one line per label 0-4.
  const std::regex row(R"(label (\d+)\s+([0-9.e+]+)\s+([0-9.e+]+) mm\^3)");
  int labels = 0;
  for (auto it = std::sregex_iterator(r.out.begin(), r.out.end(), row);
       it != std::sregex_iterator(); ++it, ++labels) {
    const double ours = std::stod((*it)[2]);
    const double theirs = std::stod((*it)[3]);
    EXPECT_GT(ours, 0.0);
    EXPECT_NEAR(theirs, ours, 1e-5 * ours) << "label " << (*it)[1];  // 6 printed digits
  }
  EXPECT_EQ(labels, 5) << r.out;
  // Without the program, or without a place for its files: one line, before any work.
  const std::string base = "mesh " + std::string(kMeshPhantom) + " --materials " +
                           four_spheres_toml() + " -o " + dir + "/bad.h5";
  const auto missing = run_hapvox(base + " --tetgen-out " + dir + "/bad --tetgen no-such-tetgen");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_EQ(missing.err,
            "hapvox: error: --tetgen: no program 'no-such-tetgen' to run (Debian: apt install "
            "tetgen)\n");
  const auto no_prefix = run_hapvox(base + " --tetgen tetgen");
  EXPECT_EQ(no_prefix.exit_code, 2);
  EXPECT_EQ(no_prefix.err,
            "hapvox: error: --tetgen: needs --tetgen-out PREFIX (where TetGen's files go)\n");
  EXPECT_FALSE(fs::exists(dir + "/bad.h5"));
  EXPECT_FALSE(fs::exists(dir + "/bad.node"));
}

TEST(MeshCli, EachBadInputIsOneLineAndExitTwo) {
  const std::string dir = scratch_dir();
  const std::string out = " -o " + dir + "/out.h5";
  const std::string phantom = std::string(kMeshPhantom);

  expect_mesh_error(dir, phantom + out, "--materials is required (see hapvox --help)");
  expect_mesh_error(dir, phantom + " --materials " + dir + "/none.toml" + out,
                    dir + "/none.toml: cannot open file");

  const std::string zero_e = write(dir + "/zero_e.toml", materials_text({0}, "0"));
  expect_mesh_error(dir, phantom + " --materials " + zero_e + out,
                    zero_e + ":3: Young's modulus must be positive and finite, got 0 Pa");
  const std::string half_nu = write(dir + "/half_nu.toml", materials_text({0}, "1e6", "0.5"));
  expect_mesh_error(dir, phantom + " --materials " + half_nu + out,
                    half_nu + ":4: Poisson's ratio must lie in (-1, 0.5), got 0.5");
  const std::string minus_one = write(dir + "/minus_one.toml", materials_text({0}, "1e6", "-1"));
  expect_mesh_error(dir, phantom + " --materials " + minus_one + out,
                    minus_one + ":4: Poisson's ratio must lie in (-1, 0.5), got -1");

  // A label the materials file lacks: from a label volume (the block's 1s), or a seed.
  const std::string two_labels = write(dir + "/two.toml", materials_text({0}));
  expect_mesh_error(dir, phantom + " --materials " + two_labels + " --labels block:dims=24" + out,
                    two_labels + ": label 1 has no material (6912 voxels)");
  const testing::FourSpheres spheres{24, 1.0};
  const engine::Vec3d red = spheres.centre_mm(2);
  expect_mesh_error(dir,
                    phantom + " --materials " + two_labels + " --seed-tolerance 0.05 --seed " +
                        std::to_string(red.x()) + "," + std::to_string(red.y()) + "," +
                        std::to_string(red.z()) + ":3" + out,
                    two_labels + ": label 3 has no material (" +
                        std::to_string(spheres.lattice_count(2)) + " voxels)");

  expect_mesh_error(
      dir, phantom + " --materials " + four_spheres_toml() + " --labels block:dims=16" + out,
      "block:dims=16: label volume is 16x16x16 voxels but the intensity volume " + phantom +
          " is 24x24x24");
  expect_mesh_error(dir, phantom + " --materials " + two_labels + out,
                    two_labels +
                        ": no labels: the file gives no intensity ranges, and no label volume "
                        "(--labels) or seeds (--seed) were given");
  expect_mesh_error(dir,
                    phantom + " --materials " + four_spheres_toml() +
                        " --labels block:dims=24 --seed 1,2,3" + out,
                    "--labels excludes --seed (see hapvox --help)");
  expect_mesh_error(dir, phantom + " --materials " + four_spheres_toml() + " --seed 1,2" + out,
                    "--seed: expected X,Y,Z, got '1,2'");
  expect_mesh_error(dir, phantom + " --materials " + four_spheres_toml() + " --seed 1,2,3:0" + out,
                    "--seed: expected a label in [1, 16777216] after ':', got '0'");

  // An output that is an input: the materials file, or the XDMF file written beside it.
  const std::string materials = write(dir + "/m.toml", materials_text({0}));
  expect_mesh_error(dir, phantom + " --materials " + materials + " -o " + materials,
                    materials + ": -o would overwrite the input materials file " + materials);
  EXPECT_EQ(testing::read_file(materials), materials_text({0}));
  const std::string xdmf = write(dir + "/in.xdmf", "<Xdmf/>");
  expect_mesh_error(dir, xdmf + " --materials " + materials + " -o " + dir + "/in.h5",
                    xdmf + ": -o's XDMF file would overwrite the input volume " + xdmf);
  EXPECT_FALSE(fs::exists(dir + "/in.h5"));
  expect_mesh_error(dir, phantom + " --materials " + materials + " -o " + dir + "/no/out.h5",
                    dir + "/no/out.h5: output directory " + dir + "/no does not exist");
}

}  // namespace
}  // namespace hapvox
