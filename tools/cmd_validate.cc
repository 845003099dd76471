// hapvox validate hertz -o DIR: the contact law against Hertz's solution for a rigid
// sphere pressed into an elastic half-space, F = 4/3 E* sqrt(R) d^1.5, E* = E / (1 - nu^2),
// over tool radii x Poisson's ratios x voxel sizes; the paper's law beside it.
//
// Writes DIR/hertz.csv (one row per depth and case) and, with matplotlib, DIR/hertz.png;
// prints each case's worst error and log-log slope over d/R in [0.02, 0.15] (depths of at
// least one voxel). Exit 3 when a case misses 5 % or a slope of 1.5 +- 0.05.

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/io/output_file.h"
#include "engine/tool_force.h"
#include "tools/cli.h"
#include "tools/drawn_pictures.h"
#include "tools/hertz_plot_script.h"
#include "tools/validate_contact.h"

namespace hapvox::cli {
namespace {

struct ValidateFlags {
  std::string out_dir = ".";
  std::string radii_mm = "2,4,8";
  std::string poisson = "0,0.3,0.45,0.49";
  std::string voxels_mm = "0.25,0.5,1";
  double youngs_modulus_pa = 100e3;
  double max_depth_ratio = 0.2;
  bool plot = true;
  std::string python = "/usr/bin/python3";
};

double hertz_force_n(double e_pa, double nu, double r_mm, double d_mm) {
  return 4.0 / 3.0 * e_pa / (1.0 - nu * nu) * std::sqrt(r_mm) * std::pow(d_mm, 1.5) * 1e-6;
}

struct ValidateRow {
  double depth_mm, hertz_law_n, paper_law_n, hertz_n;
};

// A slow vertical press (2 um a tick) into a block of voxel size h whose nominal surface
// is a voxel face, at an xy off the lattice, with both contact laws.
std::vector<ValidateRow> press(double r_mm, double h_mm, double nu, double e_pa,
                               double max_depth_mm) {
  const double footprint_mm = 2.0 * std::sqrt(2.0 * r_mm * max_depth_mm) + 4.0 * h_mm + 2.0;
  const int n = static_cast<int>(std::ceil(footprint_mm / h_mm)) + 2;
  const int top_k = static_cast<int>(std::ceil((max_depth_mm + 2.0) / h_mm)) + 2;
  engine::initialize_openvdb();
  auto grid = openvdb::FloatGrid::create(0.0f);
  grid->tree().fill(openvdb::CoordBBox({0, 0, 0}, {n - 1, n - 1, top_k - 1}), 1.0f, true);
  grid->tree().voxelizeActiveTiles();
  const engine::DensityField field(grid, engine::Vec3d::Constant(h_mm), engine::Vec3d::Zero(),
                                   engine::Vec3i(n, n, top_k + 8));
  engine::ToolForceOptions options;
  options.tool.diameter_mm = 2.0 * r_mm;
  options.material.youngs_modulus_pa = e_pa;
  options.material.poisson_ratio = nu;
  const engine::ToolForceModel hertz(field, options);
  options.contact_law = engine::ContactLaw::kPaper;
  const engine::ToolForceModel paper(field, options);
  engine::ToolForceState hertz_state = hertz.make_state();
  engine::ToolForceState paper_state = paper.make_state();
  const double face_z = (top_k - 0.5) * h_mm;
  const engine::Vec3d xy(0.5 * (n - 1) * h_mm + 0.37 * h_mm, 0.5 * (n - 1) * h_mm - 0.21 * h_mm,
                         0.0);
  std::vector<ValidateRow> rows;
  for (double depth = -h_mm; depth <= max_depth_mm; depth += 0.002) {
    const engine::Vec3d x = xy + engine::Vec3d(0, 0, face_z + r_mm - depth);
    hertz.step(x, hertz_state);
    paper.step(x, paper_state);
    if (depth > 0.0) {
      rows.push_back({depth, hertz_state.force_n.z(), paper_state.force_n.z(),
                      hertz_force_n(e_pa, nu, r_mm, depth)});
    }
  }
  return rows;
}

bool run_validate_hertz(const ValidateFlags& f) {
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
  if (!(f.max_depth_ratio >= 0.15 && f.max_depth_ratio <= 0.5)) {
    throw InputError("--max-depth-ratio", "must lie in [0.15, 0.5]");
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
  csv << "radius_mm,poisson,voxel_mm,depth_mm,force_hertz_law_n,force_paper_law_n,"
         "force_hertz_n\n";
  bool all_pass = true;
  std::printf("%6s %6s %6s %14s %12s %10s %8s\n", "R mm", "nu", "h mm", "d/R range", "max |err|",
              "slope", "verdict");
  for (double r : radii) {
    for (double nu : ratios) {
      for (double h : voxels) {
        const std::vector<ValidateRow> rows =
            press(r, h, nu, f.youngs_modulus_pa, f.max_depth_ratio * r);
        double worst = 0.0, mx = 0, my = 0;
        std::vector<std::pair<double, double>> logs;
        const double lo = std::max(0.02 * r, h), hi = 0.15 * r;
        for (const ValidateRow& row : rows) {
          char line[160];
          std::snprintf(line, sizeof line, "%g,%g,%g,%.4f,%.6g,%.6g,%.6g\n", r, nu, h, row.depth_mm,
                        row.hertz_law_n, row.paper_law_n, row.hertz_n);
          csv << line;
          if (row.depth_mm < lo || row.depth_mm > hi) continue;
          worst = std::max(worst, std::abs(row.hertz_law_n / row.hertz_n - 1.0));
          logs.emplace_back(std::log(row.depth_mm), std::log(row.hertz_law_n));
          mx += logs.back().first;
          my += logs.back().second;
        }
        if (logs.size() < 2) {
          std::printf("%6g %6g %6g %14s %12s %10s %8s\n", r, nu, h, "(none)", "-", "-", "skip");
          continue;
        }
        mx /= logs.size();
        my /= logs.size();
        double sxy = 0, sxx = 0;
        for (const auto& [x, y] : logs) sxy += (x - mx) * (y - my), sxx += (x - mx) * (x - mx);
        const double slope = sxy / sxx;
        const bool pass = worst <= 0.05 && std::abs(slope - 1.5) <= 0.05;
        all_pass = all_pass && pass;
        char range[32];
        std::snprintf(range, sizeof range, "%.3f-%.3f", lo / r, hi / r);
        std::printf("%6g %6g %6g %14s %11.2f%% %10.3f %8s\n", r, nu, h, range, 100.0 * worst, slope,
                    pass ? "ok" : "FAIL");
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
  return all_pass;
}

}  // namespace

void add_validate_command(CLI::App& app) {
  CLI::App* validate = app.add_subcommand(
      "validate", "Check the physics against closed-form solutions (exit 3 when one fails)");
  validate->require_subcommand(1);
  auto flags = std::make_shared<ValidateFlags>();
  CLI::App* cmd = validate->add_subcommand(
      "hertz",
      "The contact law against Hertz (sphere on a half-space) over tool radii, Poisson's "
      "ratios and voxel sizes: DIR/hertz.csv and DIR/hertz.png");
  cmd->add_option("--output,-o", flags->out_dir, "Directory for hertz.csv and hertz.png")
      ->capture_default_str();
  cmd->add_option("--radii-mm", flags->radii_mm, "Tool radii, mm")->capture_default_str();
  cmd->add_option("--poisson", flags->poisson, "Poisson's ratios")->capture_default_str();
  cmd->add_option("--voxels-mm", flags->voxels_mm, "Voxel sizes, mm")->capture_default_str();
  cmd->add_option("--youngs-modulus-pa,-E", flags->youngs_modulus_pa, "Young's modulus, Pa")
      ->capture_default_str();
  cmd->add_option("--max-depth-ratio", flags->max_depth_ratio,
                  "Deepest press as a fraction of the radius (the check covers d/R <= 0.15)")
      ->capture_default_str();
  cmd->add_flag("!--no-plot", flags->plot, "Write the CSV only");
  cmd->add_option("--python", flags->python, "Python with matplotlib")->capture_default_str();
  cmd->callback([flags] {
    if (!run_validate_hertz(*flags)) {
      throw ValidationFailed("the contact law misses Hertz (see the table)");
    }
  });
  add_validate_contact(*validate);
}

}  // namespace hapvox::cli
