// hapvox validate hertz -o DIR: the contact law against Hertz's solution for a rigid sphere
// pressed into elastic material, F = 4/3 E* sqrt(R*) d^1.5, E* = E / (1 - nu^2)
// (docs/physics.md, "Contact law", "Sub-voxel contact"):
//
//   flat     a block's face (R* = R) over tool radii x Poisson's ratios x voxel sizes, the
//            paper's law beside it: within 5 % from a quarter voxel deep, within 1 % from
//            one voxel (and 0.02 R) deep, log-log slope 1.5 +- 0.05; to 0.15 R;
//   curved   a sphere of radius 12 mm (R* = R R2 / (R + R2)) pressed at its pole and along
//            the grid's diagonal (the surface most oblique to the voxels), over tool radii x
//            voxel sizes, to 0.2 R*: with partial-volume edges (the `sphere` generator's
//            default) every tick from one voxel deep within 5 %; with a binary staircase
//            (edge=binary), whose surface lies anywhere within delta = h/2 |n|_1 of the
//            sphere along the normal n, every tick between 0.95 F(d - delta) and
//            1.05 F(d + delta).
//
// Every listed case runs, or the table says why it cannot (no depth of one voxel within
// the range where Hertz holds). Writes DIR/hertz.csv (one row per tick and case) and, with
// matplotlib, DIR/hertz.png; prints one line per case and one verdict. Exit 3 on a miss.

#include "tools/validate_hertz.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/io/output_file.h"
#include "engine/tool_force.h"
#include "engine/volume_io.h"
#include "tools/cli.h"
#include "tools/drawn_pictures.h"
#include "tools/hertz_plot_script.h"

namespace hapvox::cli {
namespace {

using engine::Vec3d;

struct HertzFlags {
  std::string out_dir = ".";
  std::string radii_mm = "2,4,8";
  std::string poisson = "0,0.3,0.45,0.49";
  std::string voxels_mm = "0.25,0.5,1";
  double youngs_modulus_pa = 100e3;
  bool plot = true;
  std::string python = "/usr/bin/python3";
};

constexpr double kStepMm = 0.002;  // press depth per tick
constexpr double kSphereRadiusMm = 12.0;
constexpr double kCurvedPoisson = 0.3;

double hertz_n(double e_pa, double nu, double r_mm, double d_mm) {
  if (!(d_mm > 0.0)) return 0.0;
  return 4.0 / 3.0 * e_pa / (1.0 - nu * nu) * std::sqrt(r_mm) * std::pow(d_mm, 1.5) * 1e-6;
}

engine::ToolForceOptions tool_options(double r_mm, double nu, double e_pa) {
  engine::ToolForceOptions options;
  options.tool.diameter_mm = 2.0 * r_mm;
  options.material.youngs_modulus_pa = e_pa;
  options.material.poisson_ratio = nu;
  return options;
}

// One press: the tool's centre moves along -normal from one voxel outside contact to
// max_depth_mm, kStepMm a tick; row k holds the force along `normal` (out of the material).
struct PressRow {
  double depth_mm, force_n, paper_force_n;
};

std::vector<PressRow> press(const engine::DensityField& field, const Vec3d& touch_centre_mm,
                            const Vec3d& normal, double h_mm, double max_depth_mm,
                            engine::ToolForceOptions options, bool with_paper) {
  const engine::ToolForceModel hertz(field, options);
  options.contact_law = engine::ContactLaw::kPaper;
  const engine::ToolForceModel paper(field, options);
  engine::ToolForceState hertz_state = hertz.make_state();
  engine::ToolForceState paper_state = paper.make_state();
  std::vector<PressRow> rows;
  const int ticks = static_cast<int>(std::ceil((max_depth_mm + h_mm) / kStepMm));
  for (int k = 0; k <= ticks; ++k) {
    const double depth = -h_mm + k * kStepMm;
    const Vec3d x = touch_centre_mm - depth * normal;
    hertz.step(x, hertz_state);
    if (with_paper) paper.step(x, paper_state);
    if (depth > 0.0) {
      rows.push_back({depth, hertz_state.force_n.dot(normal),
                      with_paper ? paper_state.force_n.dot(normal) : 0.0});
    }
  }
  return rows;
}

// --- flat: a block's face ---

struct FlatCase {
  double r_mm, nu, h_mm;
};

// The clay block generator's block under a tool of radius r: wide enough for the contact
// at 0.2 R, its nominal surface the voxel face at face_mm.
engine::DensityField flat_block(double r_mm, double h_mm, double* face_mm) {
  const double max_depth_mm = 0.2 * r_mm;
  const double footprint_mm = 2.0 * std::sqrt(2.0 * r_mm * max_depth_mm) + 4.0 * h_mm + 2.0;
  const int n = static_cast<int>(std::ceil(footprint_mm / h_mm)) + 2;
  const int layers = std::min(n, static_cast<int>(std::ceil((max_depth_mm + 2.0) / h_mm)) + 2);
  char spec[96];
  std::snprintf(spec, sizeof spec, "block:dims=%d,voxel_mm=%.17g,fill=%.17g", n, h_mm,
                double(layers) / n);
  *face_mm = (layers - 0.5) * h_mm;
  return engine::generate_volume(spec);
}

struct Verdicts {
  int run = 0, failed = 0, skipped = 0;
};

void check_flat(const FlatCase& c, double e_pa, std::ostringstream& csv, Verdicts& v) {
  double face_mm = 0.0;
  const engine::DensityField field = flat_block(c.r_mm, c.h_mm, &face_mm);
  const double middle = 0.5 * (field.dims().x() - 1) * c.h_mm;
  // Off the lattice, so no voxel centre lines up with the tool's axis.
  const Vec3d touch(middle + 0.37 * c.h_mm, middle - 0.21 * c.h_mm, face_mm + c.r_mm);
  const std::vector<PressRow> rows = press(field, touch, Vec3d::UnitZ(), c.h_mm, 0.2 * c.r_mm,
                                           tool_options(c.r_mm, c.nu, e_pa), true);
  const double lo_5 = 0.25 * c.h_mm, lo_1 = std::max(c.h_mm, 0.02 * c.r_mm), hi = 0.15 * c.r_mm;
  double worst_5 = 0.0, worst_1 = 0.0;
  double mx = 0.0, my = 0.0;
  std::vector<std::pair<double, double>> logs;
  for (const PressRow& row : rows) {
    const double closed = hertz_n(e_pa, c.nu, c.r_mm, row.depth_mm);
    char line[192];
    std::snprintf(line, sizeof line, "flat,%g,%g,%g,inf,0,grid,%.4f,%.6g,%.6g,%.6g,,\n", c.r_mm,
                  c.nu, c.h_mm, row.depth_mm, row.force_n, row.paper_force_n, closed);
    csv << line;
    if (row.depth_mm < lo_5 || row.depth_mm > hi) continue;
    const double error = std::abs(row.force_n / closed - 1.0);
    worst_5 = std::max(worst_5, error);
    if (row.depth_mm >= lo_1) worst_1 = std::max(worst_1, error);
    logs.emplace_back(std::log(row.depth_mm), std::log(row.force_n));
    mx += logs.back().first;
    my += logs.back().second;
  }
  char label[96];
  std::snprintf(label, sizeof label, "flat  R %g nu %g h %g", c.r_mm, c.nu, c.h_mm);
  if (logs.size() < 2) {
    std::printf("  %-34s skip: a quarter voxel is deeper than 0.15 R\n", label);
    ++v.skipped;
    return;
  }
  mx /= logs.size();
  my /= logs.size();
  double sxy = 0.0, sxx = 0.0;
  for (const auto& [x, y] : logs) sxy += (x - mx) * (y - my), sxx += (x - mx) * (x - mx);
  const double slope = sxy / sxx;
  const bool deep_checked = lo_1 <= hi;
  const bool pass =
      worst_5 <= 0.05 && (!deep_checked || worst_1 <= 0.01) && std::abs(slope - 1.5) <= 0.05;
  char deep[40];
  if (deep_checked) {
    std::snprintf(deep, sizeof deep, "%6.2f %% (1 %%)", 100.0 * worst_1);
  } else {
    std::snprintf(deep, sizeof deep, "%-14s", "(h > 0.15 R)");
  }
  std::printf("  %-34s from h/4 %5.2f %% (5 %%)  from h %s  slope %.3f  %s\n", label,
              100.0 * worst_5, deep, slope, pass ? "ok" : "FAIL");
  ++v.run;
  if (!pass) ++v.failed;
}

// --- curved: a sphere's pole and diagonal ---

struct CurvedCase {
  double r_mm, h_mm;
  bool binary;
  bool diagonal;
};

engine::DensityField sphere_volume(double h_mm, bool binary, Vec3d* centre_mm) {
  const int n = static_cast<int>(std::ceil(2.0 * kSphereRadiusMm / h_mm)) + 6;
  char spec[128];
  std::snprintf(spec, sizeof spec, "sphere:dims=%d,voxel_mm=%.17g,radius_mm=%.17g%s", n, h_mm,
                kSphereRadiusMm, binary ? ",edge=binary" : "");
  *centre_mm = Vec3d::Constant(0.5 * (n - 1) * h_mm);
  return engine::generate_volume(spec);
}

void check_curved(const CurvedCase& c, const engine::DensityField& field, const Vec3d& centre_mm,
                  double e_pa, std::ostringstream& csv, Verdicts& v) {
  const double r_star = c.r_mm * kSphereRadiusMm / (c.r_mm + kSphereRadiusMm);
  const double hi = 0.2 * r_star;
  char label[96];
  std::snprintf(label, sizeof label, "curved R %g h %g %s %s", c.r_mm, c.h_mm,
                c.diagonal ? "diagonal" : "pole", c.binary ? "binary" : "partial");
  if (c.h_mm > hi) {
    std::printf("  %-34s skip: one voxel is deeper than 0.2 R* = %.2f mm\n", label, hi);
    ++v.skipped;
    return;
  }
  const Vec3d normal =
      c.diagonal ? Vec3d(1.0, 1.0, 1.0).normalized() : Vec3d(0.0, 0.0, 1.0);  // out of it
  // The staircase lies within h/2 |n|_1 of the sphere along n (a voxel's half-extent).
  const double delta_mm = c.binary ? 0.5 * c.h_mm * normal.lpNorm<1>() : 0.0;
  const std::vector<PressRow> rows =
      press(field, centre_mm + (kSphereRadiusMm + c.r_mm) * normal, normal, c.h_mm, hi,
            tool_options(c.r_mm, kCurvedPoisson, e_pa), false);
  double worst = 0.0;  // the worst ratio's distance from the band, or from 1
  double lowest = 1e9, highest = 0.0;
  for (const PressRow& row : rows) {
    const double closed = hertz_n(e_pa, kCurvedPoisson, r_star, row.depth_mm);
    const double lower = 0.95 * hertz_n(e_pa, kCurvedPoisson, r_star, row.depth_mm - delta_mm);
    const double upper = 1.05 * hertz_n(e_pa, kCurvedPoisson, r_star, row.depth_mm + delta_mm);
    char line[224];
    std::snprintf(line, sizeof line, "curved,%g,%g,%g,%g,%d,%s,%.4f,%.6g,,%.6g,%.6g,%.6g\n", c.r_mm,
                  kCurvedPoisson, c.h_mm, kSphereRadiusMm, c.diagonal ? 1 : 0,
                  c.binary ? "binary" : "partial", row.depth_mm, row.force_n, closed, lower, upper);
    csv << line;
    if (row.depth_mm < c.h_mm || row.depth_mm > hi) continue;
    const double ratio = row.force_n / closed;
    lowest = std::min(lowest, ratio);
    highest = std::max(highest, ratio);
    worst = std::max(worst, row.force_n < lower   ? (lower - row.force_n) / closed
                            : row.force_n > upper ? (row.force_n - upper) / closed
                                                  : 0.0);
  }
  const bool pass = worst == 0.0;
  std::printf("  %-34s F/F_Hertz(R*) %.3f..%.3f per tick (%s)  %s\n", label, lowest, highest,
              c.binary ? "staircase bound" : "5 %", pass ? "ok" : "FAIL");
  ++v.run;
  if (!pass) ++v.failed;
}

bool run_validate_hertz(const HertzFlags& f) {
  const std::vector<double> radii = parse_number_list(f.radii_mm, "--radii-mm");
  const std::vector<double> ratios = parse_number_list(f.poisson, "--poisson");
  const std::vector<double> voxels = parse_number_list(f.voxels_mm, "--voxels-mm");
  for (double r : radii) {
    if (!(r > 0.0)) throw InputError("--radii-mm", "radii must be positive");
  }
  for (double nu : ratios) {
    if (!(nu > -1.0 && nu < 0.5)) throw InputError("--poisson", "ratios must lie in (-1, 0.5)");
  }
  for (double h : voxels) {
    if (!(h > 0.0)) throw InputError("--voxels-mm", "voxel sizes must be positive");
  }
  if (!(f.youngs_modulus_pa > 0.0) || !std::isfinite(f.youngs_modulus_pa)) {
    throw InputError("--youngs-modulus-pa", "must be positive");
  }
  std::error_code error;
  std::filesystem::create_directories(f.out_dir, error);
  if (!std::filesystem::is_directory(f.out_dir)) {
    throw InputError(f.out_dir, "cannot create the output directory");
  }
  const std::string csv_path = (std::filesystem::path(f.out_dir) / "hertz.csv").string();
  engine::io::check_output_target(csv_path);  // before the minutes of pressing
  if (f.plot) {
    engine::io::check_output_target((std::filesystem::path(f.out_dir) / "hertz.png").string());
  }
  std::ostringstream csv;
  csv << "case,radius_mm,poisson,voxel_mm,sphere_radius_mm,diagonal,edge,depth_mm,force_n,"
         "paper_force_n,hertz_n,lower_n,upper_n\n";
  Verdicts v;
  std::printf("E %g Pa; flat: a block's face; curved: a sphere of R2 = %g mm, nu %g\n",
              f.youngs_modulus_pa, kSphereRadiusMm, kCurvedPoisson);
  for (double r : radii) {
    for (double nu : ratios) {
      for (double h : voxels) check_flat({r, nu, h}, f.youngs_modulus_pa, csv, v);
    }
  }
  for (bool binary : {false, true}) {
    for (double h : voxels) {
      Vec3d centre_mm;
      const engine::DensityField sphere = sphere_volume(h, binary, &centre_mm);
      for (double r : radii) {
        for (bool diagonal : {false, true}) {
          check_curved({r, h, binary, diagonal}, sphere, centre_mm, f.youngs_modulus_pa, csv, v);
        }
      }
    }
  }
  engine::io::write_text_atomically(csv_path, csv.str());
  std::printf("wrote %s\n", csv_path.c_str());
  if (f.plot) {
    const int status = draw_into(f.out_dir, {"hertz.png"}, "", [&](const std::string& folder) {
      const std::string png = (std::filesystem::path(folder) / "hertz.png").string();
      return run_python_script(f.python, kHertzPlotScript, "hertz", {csv_path, png});
    });
    if (status != 0) {
      throw InputError("--python", "plotting failed (python exit status " + std::to_string(status) +
                                       "; --no-plot skips it)");
    }
  }
  std::printf("verdict: %d of %d cases hold, %d fail, %d cannot run (said why above)\n",
              v.run - v.failed, v.run, v.failed, v.skipped);
  return v.failed == 0;
}

}  // namespace

void add_validate_hertz(CLI::App& validate) {
  auto flags = std::make_shared<HertzFlags>();
  CLI::App* cmd = validate.add_subcommand(
      "hertz",
      "The contact law against Hertz: a flat face over tool radii, Poisson's ratios and voxel "
      "sizes (from a quarter voxel deep), and a sphere's pole and diagonal with partial-volume "
      "and binary edges: DIR/hertz.csv and DIR/hertz.png");
  cmd->add_option("--output,-o", flags->out_dir, "Directory for hertz.csv and hertz.png")
      ->capture_default_str();
  cmd->add_option("--radii-mm", flags->radii_mm, "Tool radii, mm")->capture_default_str();
  cmd->add_option("--poisson", flags->poisson, "Poisson's ratios (flat cases)")
      ->capture_default_str();
  cmd->add_option("--voxels-mm", flags->voxels_mm, "Voxel sizes, mm")->capture_default_str();
  cmd->add_option("--youngs-modulus-pa,-E", flags->youngs_modulus_pa, "Young's modulus, Pa")
      ->capture_default_str();
  cmd->add_flag("!--no-plot", flags->plot, "Write the CSV only");
  cmd->add_option("--python", flags->python, "Python with matplotlib")->capture_default_str();
  cmd->callback([flags] {
    if (!run_validate_hertz(*flags)) {
      throw ValidationFailed("the contact law misses Hertz (see the lines marked FAIL)");
    }
  });
}

}  // namespace hapvox::cli
