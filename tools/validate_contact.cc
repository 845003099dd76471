// hapvox validate contact -o DIR: the Hertz law's energy and friction against mechanics
// (docs/physics.md, "Why it is conservative", "Friction"), on a flat block:
//
//   energy    a press 2 mm deep, 0.8 mm off the press axis, then vertical circles of
//             r = 0.5 mm at 5 mm/s that stick: the work each returns, as a fraction of the
//             press-in work (both laws; the Hertz law must return it to 1 %);
//   friction  a pressed tool stroked back and forth (+-3 mm, mu = 0.5): F_z must stay
//             within 0.5 % of F_z at rest, |F_x| <= mu F_z, and each cycle must dissipate
//             mu F_n x the slip of the contact origin (5 %), never less than zero;
//   oblique   a press at 45 degrees: F_z within 2 % of Hertz for the depth below the face.
//
// Writes DIR/contact.csv (every tick of every case) and, with matplotlib, DIR/contact.png;
// prints one line per check and a verdict. Exit 3 when a check misses.

#include "tools/validate_contact.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>

#include "engine/errors.h"
#include "engine/io/output_file.h"
#include "engine/tool_force.h"
#include "engine/volume_io.h"
#include "tools/cli.h"
#include "tools/contact_plot_script.h"
#include "tools/drawn_pictures.h"

namespace hapvox::cli {
namespace {

using engine::Vec3d;

struct ContactFlags {
  std::string out_dir = ".";
  double voxel_mm = 0.5;
  double youngs_modulus_pa = 100e3;
  double poisson_ratio = 0.45;
  bool plot = true;
  std::string python = "/usr/bin/python3";
};

constexpr double kRadiusMm = 4.0;
constexpr double kTickS = 1e-3;

// The clay block generator's block, 40 mm wide at voxel size h, full up to the voxel face
// nearest 8 mm above its floor (its nominal surface, face_mm).
engine::DensityField contact_block(double h_mm) {
  const int n = static_cast<int>(std::ceil(40.0 / h_mm));
  const int top_k = static_cast<int>(std::ceil(8.0 / h_mm));
  char spec[96];
  std::snprintf(spec, sizeof spec, "block:dims=%d,voxel_mm=%.17g,fill=%.17g", n, h_mm,
                double(top_k) / n);
  return engine::generate_volume(spec);
}

double face_mm(double h_mm) { return (std::ceil(8.0 / h_mm) - 0.5) * h_mm; }

// Moves the tool tick by tick and keeps the hand's work W = -sum F . dx (trapezoidal), and
// every tick as a CSV row of `csv` under `case_name`.
class Probe {
 public:
  Probe(const engine::ToolForceModel& model, const Vec3d& start, std::string case_name,
        std::ostringstream& csv, double top_mm)
      : model_(model),
        state_(model.make_state()),
        x_(start),
        case_(std::move(case_name)),
        csv_(csv),
        top_mm_(top_mm) {
    model_.step(x_, state_);
  }
  void move_to(const Vec3d& target) {
    const Vec3d before = state_.force_n;
    const Vec3d from = x_;
    x_ = target;
    model_.step(x_, state_);
    work_mj_ -= 0.5 * (before + state_.force_n).dot(x_ - from);
    slip_mm_ += (state_.contact_origin_mm - origin_).norm();
    origin_ = state_.contact_origin_mm;
    // Hertz for the depth of the tool's lowest point below the face.
    const engine::ElasticMaterial& m = model_.options().material;
    const double depth_mm = std::max(0.0, top_mm_ - x_.z());
    const double hertz_n = 4.0 / 3.0 * m.youngs_modulus_pa /
                           (1.0 - m.poisson_ratio * m.poisson_ratio) * std::sqrt(kRadiusMm) *
                           std::pow(depth_mm, 1.5) * 1e-6;
    hertz_n_ = hertz_n;
    char line[220];
    std::snprintf(line, sizeof line, "%s,%d,%.5f,%.5f,%.5f,%.7g,%.7g,%.7g,%.7g,%.7g\n",
                  case_.c_str(), ticks_++, x_.x(), x_.y(), x_.z(), state_.force_n.x(),
                  state_.force_n.z(), state_.normal_force_n, hertz_n, work_mj_);
    csv_ << line;
  }
  void line_to(const Vec3d& target, double speed_mm_s) {
    const Vec3d start = x_;
    const int n = std::max(1, int(std::ceil((target - start).norm() / (speed_mm_s * kTickS))));
    for (int i = 1; i <= n; ++i) move_to(start + (target - start) * (double(i) / n));
  }
  const engine::ToolForceState& state() const { return state_; }
  const Vec3d& x() const { return x_; }
  /// Names the rows from here on (a case's phases: its press, its loops).
  void set_case(std::string case_name) { case_ = std::move(case_name); }
  double work_mj() const { return work_mj_; }
  double hertz_n() const { return hertz_n_; }
  double slip_mm() const { return slip_mm_; }

 private:
  const engine::ToolForceModel& model_;
  engine::ToolForceState state_;
  Vec3d x_;
  Vec3d origin_ = Vec3d::Zero();
  std::string case_;
  std::ostringstream& csv_;
  double top_mm_;  // the tool centre where its lowest point reaches the face
  double work_mj_ = 0.0, slip_mm_ = 0.0, hertz_n_ = 0.0;
  int ticks_ = 0;
};

engine::ToolForceOptions options_of(const ContactFlags& f, engine::ContactLaw law, double mu) {
  engine::ToolForceOptions o;
  o.tool.diameter_mm = 2.0 * kRadiusMm;
  o.material.youngs_modulus_pa = f.youngs_modulus_pa;
  o.material.poisson_ratio = f.poisson_ratio;
  o.contact_law = law;
  o.friction_coefficient = mu;
  return o;
}

bool report(const char* check, double value, double bound, const char* unit) {
  const bool pass = std::abs(value) <= bound;
  std::printf("  %-58s %+9.3f %s (bound %.2f)  %s\n", check, value, unit, bound,
              pass ? "ok" : "FAIL");
  return pass;
}

// The audit's sticking loops, with each law; returns whether the Hertz law's hold.
bool check_energy(const engine::DensityField& field, const ContactFlags& f,
                  std::ostringstream& csv) {
  bool pass = true;
  const double top = face_mm(f.voxel_mm) + kRadiusMm;
  for (const engine::ContactLaw law : {engine::ContactLaw::kHertz, engine::ContactLaw::kPaper}) {
    const engine::ToolForceModel model(field, options_of(f, law, INFINITY));
    const std::string name = std::string("energy_") + engine::contact_law_name(law);
    const Vec3d axis(20.1, 19.9, 0.0);
    Probe probe(model, axis + Vec3d(0, 0, top + 0.5), name + "_press", csv, top);
    probe.line_to(axis + Vec3d(0, 0, top - 2.0), 5.0);
    const double press_in_mj = probe.work_mj();
    probe.set_case(name + "_loops");
    const Vec3d centre = axis + Vec3d(0.8, 0, top - 2.0);
    probe.line_to(centre + Vec3d(0.5, 0, 0), 5.0);
    const int ticks = static_cast<int>(2.0 * std::numbers::pi * 0.5 / (5.0 * kTickS));
    for (int loop = 1; loop <= 3; ++loop) {
      const double before = probe.work_mj();
      for (int i = 1; i <= ticks; ++i) {
        const double phi = 2.0 * std::numbers::pi * i / ticks;
        probe.move_to(centre + 0.5 * Vec3d(std::cos(phi), 0, std::sin(phi)));
      }
      const double percent = 100.0 * (probe.work_mj() - before) / press_in_mj;
      char check[96];
      std::snprintf(check, sizeof check, "energy, %s law, sticking loop %d: %% of press-in work",
                    engine::contact_law_name(law), loop);
      if (law == engine::ContactLaw::kHertz) {
        pass = report(check, percent, 1.0, "%") && pass;
      } else {
        std::printf("  %-58s %+9.3f %%  (the seed's law, for comparison)\n", check, percent);
      }
    }
  }
  return pass;
}

// Two back-and-forth strokes of +-3 mm at 5 mm/s, 1.5 mm deep, mu = 0.5.
bool check_friction(const engine::DensityField& field, const ContactFlags& f,
                    std::ostringstream& csv) {
  const double mu = 0.5;
  const engine::ToolForceModel model(field, options_of(f, engine::ContactLaw::kHertz, mu));
  const double z = face_mm(f.voxel_mm) + kRadiusMm - 1.5;
  const Vec3d start(20.1, 19.9, z);
  Probe probe(model, start + Vec3d(0, 0, 2.0), "friction", csv, z + 1.5);
  probe.line_to(start, 5.0);
  const double at_rest_n = probe.state().force_n.z();
  probe.line_to(start + Vec3d(3, 0, 0), 5.0);  // the first stretch to the bound
  double most_off = 0.0, most_over = 0.0, normal_sum = 0.0;
  int count = 0;
  const double before_mj = probe.work_mj(), slip_before_mm = probe.slip_mm();
  for (int cycle = 0; cycle < 2; ++cycle) {
    for (const double x_mm : {-3.0, 3.0}) {
      const Vec3d from = probe.x(), to = start + Vec3d(x_mm, 0, 0);
      const int n = static_cast<int>(std::ceil((to - from).norm() / (5.0 * kTickS)));
      for (int i = 1; i <= n; ++i) {
        probe.move_to(from + (to - from) * (double(i) / n));
        const Vec3d force = probe.state().force_n;
        most_off = std::max(most_off, std::abs(force.z() / at_rest_n - 1.0));
        most_over = std::max(most_over, std::abs(force.x()) / (mu * force.z()) - 1.0);
        normal_sum += probe.state().normal_force_n;
        ++count;
      }
    }
  }
  const double dissipated_mj = probe.work_mj() - before_mj;
  const double coulomb_mj = mu * normal_sum / count * (probe.slip_mm() - slip_before_mm);
  bool pass = report("friction: F_z while stroking vs at rest", 100.0 * most_off, 0.5, "%");
  pass = report("friction: |F_x| above mu F_z", 100.0 * std::max(0.0, most_over), 0.5, "%") && pass;
  pass = report("friction: dissipated vs mu F_n x slip", 100.0 * (dissipated_mj / coulomb_mj - 1.0),
                5.0, "%") &&
         pass;
  const bool dissipates = dissipated_mj > 0.0;
  std::printf("  %-58s %9.4f mJ  %s\n", "friction: work the strokes dissipated", dissipated_mj,
              dissipates ? "ok" : "FAIL");
  return pass && dissipates;
}

// A press at 45 degrees into the face, mu = 0.5.
bool check_oblique(const engine::DensityField& field, const ContactFlags& f,
                   std::ostringstream& csv) {
  const engine::ToolForceModel model(field, options_of(f, engine::ContactLaw::kHertz, 0.5));
  const double top = face_mm(f.voxel_mm) + kRadiusMm;
  const Vec3d start(12.13, 20.07, top + 0.5);
  Probe probe(model, start, "oblique", csv, top);
  double worst = 0.0;
  const Vec3d direction = Vec3d(1, 0, -1).normalized();
  const double end_mm = std::sqrt(2.0) * (0.5 + 0.15 * kRadiusMm);
  for (double s = 0.0; s < end_mm; s += 0.002) {
    probe.move_to(start + s * direction);
    const double depth_mm = top - probe.x().z();
    if (depth_mm < f.voxel_mm || depth_mm > 0.15 * kRadiusMm) continue;
    worst = std::max(worst, std::abs(probe.state().force_n.z() / probe.hertz_n() - 1.0));
  }
  return report("oblique press at 45 degrees: F_z vs Hertz, worst", 100.0 * worst, 2.0, "%");
}

bool run_validate_contact(const ContactFlags& f) {
  std::error_code error;
  std::filesystem::create_directories(f.out_dir, error);
  if (!std::filesystem::is_directory(f.out_dir)) {
    throw InputError(f.out_dir, "cannot create the output directory");
  }
  const std::string csv_path = (std::filesystem::path(f.out_dir) / "contact.csv").string();
  engine::io::check_output_target(csv_path);
  if (f.plot) {
    engine::io::check_output_target((std::filesystem::path(f.out_dir) / "contact.png").string());
  }
  const engine::DensityField field = contact_block(f.voxel_mm);
  std::ostringstream csv;
  csv << "case,tick,x_mm,y_mm,z_mm,force_x_n,force_z_n,normal_force_n,hertz_n,work_mj\n";
  std::printf("R %g mm, E %g Pa, nu %g, voxels %g mm\n", kRadiusMm, f.youngs_modulus_pa,
              f.poisson_ratio, f.voxel_mm);
  bool pass = check_energy(field, f, csv);
  pass = check_friction(field, f, csv) && pass;
  pass = check_oblique(field, f, csv) && pass;
  engine::io::write_text_atomically(csv_path, csv.str());
  std::printf("wrote %s\n", csv_path.c_str());
  if (f.plot) {
    const int status = draw_into(f.out_dir, {"contact.png"}, "", [&](const std::string& folder) {
      const std::string png = (std::filesystem::path(folder) / "contact.png").string();
      return run_python_script(f.python, kContactPlotScript, "contact", {csv_path, png});
    });
    if (status != 0) {
      throw InputError("--python", "plotting failed (python exit status " + std::to_string(status) +
                                       "; --no-plot skips it)");
    }
  }
  std::printf("verdict: %s\n", pass ? "every check holds" : "a check misses (FAIL above)");
  return pass;
}

}  // namespace

void add_validate_contact(CLI::App& validate) {
  auto flags = std::make_shared<ContactFlags>();
  CLI::App* cmd = validate.add_subcommand(
      "contact",
      "The Hertz law's energy on sticking loops, Coulomb friction on a stroke and a 45-degree "
      "press: DIR/contact.csv and DIR/contact.png");
  cmd->add_option("--output,-o", flags->out_dir, "Directory for contact.csv and contact.png")
      ->capture_default_str();
  cmd->add_option("--voxel-mm", flags->voxel_mm, "Voxel size of the block, mm")
      ->capture_default_str();
  cmd->add_option("--youngs-modulus-pa,-E", flags->youngs_modulus_pa, "Young's modulus, Pa")
      ->capture_default_str();
  cmd->add_option("--poisson", flags->poisson_ratio, "Poisson's ratio")->capture_default_str();
  cmd->add_flag("!--no-plot", flags->plot, "Write the CSV only");
  cmd->add_option("--python", flags->python, "Python with matplotlib")->capture_default_str();
  cmd->callback([flags] {
    if (!run_validate_contact(*flags)) {
      throw ValidationFailed("the contact law misses a check (see the lines marked FAIL)");
    }
  });
}

}  // namespace hapvox::cli
