// Nakao et al.'s Fig. 5 on the four-spheres phantom (32^3 here; scripts/fig5.sh runs 128^3):
// the red sphere grabbed and moved toward the blue one, once with the paper's moduli (green
// 100 MPa, blue 0.1 MPa, red and background 10 MPa, white 1 MPa) and once homogeneous (all
// 10 MPa). The issue asks for the hard sphere's mean strain to be at most 1 % of the soft
// one's; elasticity does not allow that with these moduli. Eshelby's dilute solution for a
// sphere in a matrix strained far away gives the sphere's deviatoric strain as
// 1 / (1 + beta (mu_s / mu_m - 1)) of the far field, beta = 2 (4 - 5 nu) / (15 (1 - nu)) =
// 0.424 at nu = 0.45: 0.207 for the green sphere (10x the background), 1.72 for the blue one
// (0.01x), a ratio of 0.12 (docs/physics.md). Measured here: 0.0995 (uniform moduli: 0.746).
// The test holds the ratio to Eshelby's estimate within a factor of two, far below the
// uniform case's, and the two displacement fields apart.

#include <gtest/gtest.h>

#include <Eigen/Core>

#include <fstream>

#include "engine/fem/strain.h"
#include "engine/labels/four_spheres.h"
#include "haptics/mesh_file.h"
#include "haptics/session.h"
#include "test_data.h"

namespace hapvox {
namespace {

using testing::run_hapvox;
using testing::scratch_dir;
using testing::source_path;

constexpr int kBlue = 1;
constexpr int kGreen = 2;
constexpr int kRed = 3;

// From the red sphere's centre, `travel_mm` toward the blue one's over 0.2 s, then held.
std::string write_grab_trace(const std::string& dir, double travel_mm) {
  const testing::FourSpheres phantom{32, 1.0};
  const engine::Vec3d start = phantom.centre_mm(kRed - 1);
  const engine::Vec3d toward = (phantom.centre_mm(kBlue - 1) - start).normalized();
  const std::string path = dir + "/grab.csv";
  std::ofstream out(path);
  out << "t,x,y,z\n";
  for (int k = 0; k <= 300; ++k) {
    const engine::Vec3d p = start + travel_mm * std::min(1.0, k / 200.0) * toward;
    out << k / 1000.0 << "," << p.x() << "," << p.y() << "," << p.z() << "\n";
  }
  return path;
}

struct GrabRun {
  engine::fem::TetMesh mesh;
  Eigen::VectorXd last_displacement_mm;
  std::map<std::int32_t, engine::fem::LabelStrain> strain;
  std::string info;
};

GrabRun grab(const std::string& dir, const std::string& trace, const std::string& materials,
             const std::string& name) {
  const std::string session = dir + "/" + name + ".h5";
  const auto r =
      run_hapvox("replay " + trace + " --volume four-spheres:dims=32 --model fem --materials " +
                 source_path(materials) +
                 " --boundary-levels 1 --interaction grab --tool-diameter-mm 6 --ramp-in-s 0"
                 " --max-force-n 1000 --coupling-n-per-mm 1000 -q -o " +
                 session);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  GrabRun run;
  run.mesh = haptics::read_tet_mesh(session);
  const std::vector<double> u = haptics::read_session_column(session, "fem/displacement_mm");
  const std::size_t per_step = 3 * static_cast<std::size_t>(run.mesh.vertex_count());
  run.last_displacement_mm = Eigen::Map<const Eigen::VectorXd>(u.data() + u.size() - per_step,
                                                               static_cast<Eigen::Index>(per_step));
  run.strain = engine::fem::mean_strain_by_label(run.mesh, run.last_displacement_mm);
  const auto info = run_hapvox("info " + session);
  EXPECT_EQ(info.exit_code, 0) << info.err;
  run.info = info.out;
  return run;
}

TEST(Fig5, HardToSoftSphereStrainIsEshelbysFractionAndUniformModuliDifferMeasurably) {
  const std::string dir = scratch_dir();
  const std::string trace = write_grab_trace(dir, 3.0);
  const GrabRun paper = grab(dir, trace, "data/four_spheres.toml", "paper");
  const GrabRun uniform = grab(dir, trace, "data/four_spheres_homogeneous.toml", "uniform");
  ASSERT_EQ(paper.strain.size(), 5u);
  ASSERT_EQ(uniform.strain.size(), 5u);
  // The same labels give the same mesh: the fields compare vertex by vertex.
  ASSERT_EQ(paper.mesh.rest_mm, uniform.mesh.rest_mm);

  const double paper_ratio =
      paper.strain.at(kGreen).mean_strain_norm / paper.strain.at(kBlue).mean_strain_norm;
  const double uniform_ratio =
      uniform.strain.at(kGreen).mean_strain_norm / uniform.strain.at(kBlue).mean_strain_norm;
  const double eshelby_ratio = 0.207 / 1.724;
  EXPECT_GT(paper_ratio, 0.5 * eshelby_ratio);
  EXPECT_LT(paper_ratio, 2.0 * eshelby_ratio);
  EXPECT_GT(paper.strain.at(kBlue).mean_strain_norm, 0.0);
  // Uniform moduli: what kept the green sphere still was its stiffness, not its place.
  EXPECT_GT(uniform_ratio, 5 * paper_ratio);
  // The grabbed sphere moved as far in both (displacement control through a stiff coupling),
  // and the fields still differ by much more than round-off.
  const double difference = (paper.last_displacement_mm - uniform.last_displacement_mm).norm() /
                            uniform.last_displacement_mm.norm();
  EXPECT_GT(difference, 0.03);
  std::printf("green/blue mean strain: paper %.3g, uniform %.3g; fields differ by %.1f %%\n",
              paper_ratio, uniform_ratio, 100 * difference);
  EXPECT_NE(paper.info.find("strain at the last FEM step (tick 299)"), std::string::npos)
      << paper.info;
}

}  // namespace
}  // namespace hapvox
