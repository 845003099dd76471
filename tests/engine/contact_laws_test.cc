// The Hertz law's energy, friction and plastic loading (issue 28; docs/physics.md,
// "Contact law", "Friction", "Incremental plasticity"): a sticking closed loop returns the
// work put in, a sliding loop dissipates the Coulomb work, sliding keeps the normal force,
// an oblique press feels Hertz along the normal, yield begins at Hertz's mean pressure and
// a sideways plastic stroke has no force step.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include "engine/block_field.h"
#include "engine/tool_force.h"

namespace hapvox::engine {
namespace {

constexpr double kToolRadiusMm = 4.0;

// A block of n x n voxels of size h_mm, full below index z = top_k, room above its face.
DensityField energy_block(int n, int top_k, double h_mm) {
  return fixtures::make_block(n, top_k, Vec3d::Constant(h_mm), top_k + 12);
}

double face_height_mm(int top_k, double h_mm) { return (top_k - 0.5) * h_mm; }

// Hertz: F = 4/3 E* sqrt(R) d^1.5 (N) for a rigid sphere on an elastic half-space.
double hertz_newtons(const ElasticMaterial& m, double radius_mm, double depth_mm) {
  const double e_star = m.youngs_modulus_pa / (1.0 - m.poisson_ratio * m.poisson_ratio);
  return 4.0 / 3.0 * e_star * std::sqrt(radius_mm) * std::pow(depth_mm, 1.5) * 1e-6;
}

ToolForceOptions hertz_options(double friction) {
  ToolForceOptions options;
  options.tool.diameter_mm = 2.0 * kToolRadiusMm;
  options.material.youngs_modulus_pa = 100e3;
  options.material.poisson_ratio = 0.45;
  options.friction_coefficient = friction;
  return options;
}

// Drives a model along a path at 1 kHz and keeps the work the hand does on the tool,
// W = -sum F . dx (trapezoidal), so a positive W is energy the contact took in.
struct Stroke {
  const ToolForceModel& model;
  ToolForceState state;
  Vec3d x = Vec3d::Zero();
  double work_mj = 0.0;  // N mm = mJ
  int slipping_ticks = 0;

  Stroke(const ToolForceModel& m, const Vec3d& start) : model(m), state(m.make_state()), x(start) {
    model.step(x, state);
  }
  void move_to(const Vec3d& target) {
    const Vec3d before = state.force_n;
    const Vec3d from = x;
    x = target;
    model.step(x, state);
    work_mj -= 0.5 * (before + state.force_n).dot(x - from);
    slipping_ticks += state.slipping;
  }
  // Straight to `target` at speed_mm_s.
  void line_to(const Vec3d& target, double speed_mm_s) {
    const Vec3d start = x;
    const int ticks =
        std::max(1, static_cast<int>(std::ceil((target - start).norm() / (speed_mm_s * 1e-3))));
    for (int i = 1; i <= ticks; ++i) move_to(start + (target - start) * (double(i) / ticks));
  }
};

// The audit's loop: pressed 2 mm into the face, moved 0.8 mm off the press axis, then a
// circle of radius 0.5 mm in the vertical xz plane at 5 mm/s.
TEST(ContactEnergy, AStickingClosedLoopReturnsTheWorkPutIn) {
  const double h = 0.5;
  const DensityField field = energy_block(48, 16, h);
  const double top = face_height_mm(16, h) + kToolRadiusMm;  // tool centre at first contact
  for (const double friction : {double(INFINITY), 4.0}) {
    const ToolForceModel model(field, hertz_options(friction));
    const Vec3d axis(12.1, 11.9, 0.0);
    Stroke stroke(model, axis + Vec3d(0, 0, top + 0.5));
    stroke.line_to(axis + Vec3d(0, 0, top - 2.0), 5.0);
    const double press_in_mj = stroke.work_mj;
    ASSERT_GT(press_in_mj, 0.1);
    const Vec3d centre = axis + Vec3d(0.8, 0, top - 2.0);
    stroke.line_to(centre + Vec3d(0.5, 0, 0), 5.0);
    const int ticks_per_loop = static_cast<int>(2.0 * std::numbers::pi * 0.5 / 5e-3);
    for (int loop = 0; loop < 3; ++loop) {
      const double before_mj = stroke.work_mj;
      for (int i = 1; i <= ticks_per_loop; ++i) {
        const double phi = 2.0 * std::numbers::pi * i / ticks_per_loop;
        stroke.move_to(centre + 0.5 * Vec3d(std::cos(phi), 0, std::sin(phi)));
      }
      const double loop_mj = stroke.work_mj - before_mj;
      std::printf("friction %g, loop %d: %+.5f mJ of %.4f mJ pressed in (%+.3f %%)\n", friction,
                  loop, loop_mj, press_in_mj, 100.0 * loop_mj / press_in_mj);
      EXPECT_LE(std::abs(loop_mj), 0.01 * press_in_mj) << friction << " loop " << loop;
    }
    EXPECT_EQ(stroke.slipping_ticks, 0) << friction;  // it stuck all the way
  }
}

// A horizontal circle at constant depth with mu = 0.5: after the first quarter the contact
// slides all the way round, and the hand pays mu F_n for every millimetre the contact
// origin slips (the tool's path, less the spring's stretch it trails by).
TEST(ContactEnergy, ASlidingLoopDissipatesTheCoulombWork) {
  const double h = 0.5;
  const DensityField field = energy_block(64, 16, h);
  const double top = face_height_mm(16, h) + kToolRadiusMm;
  for (const double depth_mm : {0.8, 1.5}) {
    const ToolForceModel model(field, hertz_options(0.5));
    const Vec3d centre(16.1, 15.9, top - depth_mm);
    const double radius_mm = 5.0;
    Stroke stroke(model, centre + Vec3d(radius_mm, 0, 0.5 + depth_mm));
    stroke.line_to(centre + Vec3d(radius_mm, 0, 0), 5.0);
    const int ticks = static_cast<int>(2.0 * std::numbers::pi * radius_mm / 5e-3);
    auto go_round = [&] {
      for (int i = 1; i <= ticks; ++i) {
        const double phi = 2.0 * std::numbers::pi * i / ticks;
        stroke.move_to(centre + radius_mm * Vec3d(std::cos(phi), std::sin(phi), 0));
      }
    };
    go_round();  // the spring stretches to the bound and stays there
    const double before_mj = stroke.work_mj;
    double normal_n = 0.0, path_mm = 0.0, slip_mm = 0.0;
    Vec3d origin = stroke.state.contact_origin_mm;
    for (int i = 1; i <= ticks; ++i) {
      const double phi = 2.0 * std::numbers::pi * i / ticks;
      const Vec3d before = stroke.x;
      stroke.move_to(centre + radius_mm * Vec3d(std::cos(phi), std::sin(phi), 0));
      path_mm += (stroke.x - before).norm();
      slip_mm += (stroke.state.contact_origin_mm - origin).norm();
      origin = stroke.state.contact_origin_mm;
      normal_n += stroke.state.normal_force_n / ticks;
    }
    const double loop_mj = stroke.work_mj - before_mj;
    const double coulomb_mj = 0.5 * normal_n * path_mm;
    std::printf("depth %.1f mm: loop %.4f mJ, mu F_n path %.4f mJ (%.2f %%), mu F_n slip %.4f mJ\n",
                depth_mm, loop_mj, coulomb_mj, 100.0 * (loop_mj / coulomb_mj - 1.0),
                0.5 * normal_n * slip_mm);
    EXPECT_GT(loop_mj, 0.0);  // never generates energy
    EXPECT_NEAR(loop_mj, coulomb_mj, 0.05 * coulomb_mj) << depth_mm;
    // Exactly the work of the slip itself.
    EXPECT_NEAR(loop_mj, 0.5 * normal_n * slip_mm, 0.005 * loop_mj) << depth_mm;
    EXPECT_GT(stroke.slipping_ticks, ticks);  // it slid nearly all the way, both times
  }
}

// Sliding does not take normal force away: a pressed tool dragged along the face feels the
// F_z it felt at rest (to the quadrature's ripple along the face) and the F_z a frictionless
// tool feels at the same place, with a tangential force on the Coulomb bound mu F_n. (The
// force along u of the old law fell from 0.822 to 0.735 N, x 1 / sqrt(1 + mu^2).)
TEST(ContactEnergy, SlidingKeepsTheNormalForceAndSitsOnTheCoulombBound) {
  const double h = 0.5;
  const DensityField field = energy_block(120, 24, h);
  const double top = face_height_mm(24, h) + kToolRadiusMm;
  const double depth_mm = 1.5;
  const ToolForceModel frictionless(field, hertz_options(0.0));
  for (const double mu : {0.3, 0.5, 1.0}) {
    const ToolForceModel model(field, hertz_options(mu));
    Stroke stroke(model, Vec3d(10, 30, top + 1.0));
    Stroke free(frictionless, Vec3d(10, 30, top + 1.0));
    stroke.line_to(Vec3d(10, 30, top - depth_mm), 2.0);
    free.line_to(Vec3d(10, 30, top - depth_mm), 2.0);
    const double at_rest_n = stroke.state.force_n.z();
    ASSERT_NEAR(at_rest_n, hertz_newtons(model.options().material, kToolRadiusMm, depth_mm),
                0.01 * at_rest_n);
    int slipping = 0;
    double most_off_rest = 0.0, most_off_free = 0.0;
    for (double x = 10.0; x <= 40.0; x += 0.01) {
      stroke.move_to(Vec3d(x, 30, top - depth_mm));
      free.move_to(Vec3d(x, 30, top - depth_mm));
      const Vec3d f = stroke.state.force_n;
      const double f_t = std::hypot(f.x(), f.y());
      most_off_rest = std::max(most_off_rest, std::abs(f.z() / at_rest_n - 1.0));
      most_off_free = std::max(most_off_free, std::abs(f.z() / free.state.force_n.z() - 1.0));
      ASSERT_LE(f_t, mu * f.z() * (1.0 + 5e-3)) << "x " << x;
      if (x > 15.0) {
        ASSERT_TRUE(stroke.state.slipping) << x;
        ASSERT_NEAR(f_t, mu * f.z(), 5e-3 * mu * f.z()) << "x " << x;
        ASSERT_LT(f.x(), 0.0);  // opposes the motion
        ++slipping;
      }
    }
    std::printf("mu %.1f: sliding F_z within %.3f %% of at rest, %.4f %% of frictionless\n", mu,
                100.0 * most_off_rest, 100.0 * most_off_free);
    EXPECT_LE(most_off_rest, 0.005) << mu;
    EXPECT_LE(most_off_free, 0.001) << mu;
    EXPECT_GT(slipping, 2000);
  }
}

// A tool pushed right under the face, where uniform material all round gives N = 0 and no
// contact normal, keeps its contact origin: on the way back it feels what it felt on the
// way in (the slip rule has no plane to slip in there).
TEST(ContactEnergy, ABuriedToolKeepsItsOriginAndFeelsTheSameOnTheWayOut) {
  const double h = 0.5;
  const DensityField field = energy_block(48, 40, h);
  const double top = face_height_mm(40, h) + kToolRadiusMm;
  const ToolForceModel model(field, hertz_options(0.5));
  Stroke stroke(model, Vec3d(12.1, 11.9, top + 0.5));
  stroke.line_to(Vec3d(12.1, 11.9, top - 1.0), 2.0);
  const double on_the_way_in_n = stroke.state.force_n.z();
  ASSERT_GT(on_the_way_in_n, 0.1);
  stroke.line_to(Vec3d(12.1, 11.9, top - 10.0), 2.0);  // the whole sphere under the face
  EXPECT_EQ(stroke.state.contact.samples_in_contact, model.surface_sample_count());
  stroke.line_to(Vec3d(12.1, 11.9, top - 1.0), 2.0);
  EXPECT_NEAR(stroke.state.force_n.z(), on_the_way_in_n, 1e-3 * on_the_way_in_n);
}

// A press at 45 degrees into the face: friction takes the tangential part, and the normal
// force is Hertz's for the depth below the nominal surface.
TEST(ContactEnergy, AnObliquePressFeelsHertzAlongTheNormal) {
  for (const double h : {0.5, 0.25}) {
    const int top_k = static_cast<int>(std::round(8.0 / h));
    const DensityField field = energy_block(static_cast<int>(std::round(40.0 / h)), top_k, h);
    const double top = face_height_mm(top_k, h) + kToolRadiusMm;
    for (const double mu : {0.5, 1.0}) {
      const ToolForceModel model(field, hertz_options(mu));
      const Vec3d start(10.13, 20.07, top + 0.5);
      Stroke stroke(model, start);
      const Vec3d direction = Vec3d(1, 0, -1).normalized();
      int checked = 0;
      for (double s = 0.0; s < 2.0 * std::sqrt(2.0); s += 0.002) {
        stroke.move_to(start + s * direction);
        const double depth_mm = top - stroke.x.z();
        if (depth_mm < h || depth_mm > 0.5 * kToolRadiusMm * 0.6) continue;
        const double hertz_n = hertz_newtons(model.options().material, kToolRadiusMm, depth_mm);
        ASSERT_NEAR(stroke.state.force_n.z(), hertz_n, 0.02 * hertz_n)
            << "h " << h << ", mu " << mu << ", depth " << depth_mm;
        ASSERT_LE(std::abs(stroke.state.force_n.x()), mu * stroke.state.force_n.z() * 1.005);
        ++checked;
      }
      EXPECT_GT(checked, 200);
    }
  }
}

// Yield begins where Hertz's mean pressure p_m = F / (pi a^2) = 4 E* / (3 pi) sqrt(d / R)
// reaches sigma_f, at d_y = R (3 pi sigma_f / (4 E*))^2 (Johnson, Contact Mechanics, 4.2
// and 6.1). The measure was F / |N|, half of it: first yield came at 0.64 mm instead of
// 0.18 mm for sigma_f = 10 kPa.
TEST(ContactPlasticity, YieldBeginsWhereHertzsMeanPressureReachesTheYieldStress) {
  const double e = 100e3, nu = 0.3;
  const double e_star = e / (1.0 - nu * nu);
  for (const double h : {1.0, 0.5}) {
    for (const double sigma_f : {10e3, 30e3}) {
      const double onset_mm =
          kToolRadiusMm * std::pow(3.0 * std::numbers::pi * sigma_f / (4.0 * e_star), 2);
      const int n = static_cast<int>(std::ceil(24.0 / h));
      const int top_k = static_cast<int>(std::ceil(6.0 / h));
      const DensityField field = energy_block(n, top_k, h);
      ToolForceOptions options = hertz_options(0.5);
      options.material.poisson_ratio = nu;
      options.plastic.enabled = true;
      options.plastic.yield_stress_pa = sigma_f;
      const ToolForceModel model(field, options);
      ToolForceState state = model.make_state();
      const Vec3d xy(0.5 * (n - 1) * h + 0.37 * h, 0.5 * (n - 1) * h - 0.21 * h, 0.0);
      double first_yield_mm = -1.0;
      for (double depth = -h; depth <= 3.0 && first_yield_mm < 0.0; depth += 0.002) {
        model.step(xy + Vec3d(0, 0, face_height_mm(top_k, h) + kToolRadiusMm - depth), state);
        if (state.zone == PlasticZone::kPlasticLoad) first_yield_mm = depth;
      }
      ASSERT_GT(first_yield_mm, 0.0) << h << " " << sigma_f;
      EXPECT_NEAR(first_yield_mm, onset_mm, h) << "h " << h << ", sigma_f " << sigma_f;
      std::printf("yield onset, h %.2f mm, sigma_f %.0f Pa: %.3f mm (Hertz %.3f mm)\n", h, sigma_f,
                  first_yield_mm, onset_mm);
    }
  }
}

// While flowing, the return mapping holds the mean pressure over Hertz's contact area at
// sigma_f: F_n = sigma_f pi a^2, far below the elastic force at the same depth.
TEST(ContactPlasticity, PerfectlyPlasticLoadHoldsHertzsMeanPressureAtTheYieldStress) {
  const double h = 0.5;
  const DensityField field = energy_block(48, 24, h);
  ToolForceOptions options = hertz_options(0.5);
  options.material.youngs_modulus_pa = 200e3;
  options.plastic.enabled = true;
  options.plastic.yield_stress_pa = 15e3;
  const ToolForceModel model(field, options);
  ToolForceState plastic = model.make_state();
  ToolForceOptions elastic_options = options;
  elastic_options.plastic.enabled = false;
  const ToolForceModel elastic_model(field, elastic_options);
  ToolForceState elastic = elastic_model.make_state();
  const double top = face_height_mm(24, h) + kToolRadiusMm;
  int flowing = 0;
  for (double z = top + 0.5; z > top - 2.0; z -= 0.002) {
    const Vec3d x(12.1, 11.9, z);
    model.step(x, plastic);
    elastic_model.step(x, elastic);
    if (plastic.zone != PlasticZone::kPlasticLoad) continue;
    const double a_mm = plastic.contact.contact_radius_mm();
    const double yield_n = 15e3 * std::numbers::pi * a_mm * a_mm * 1e-6;
    ASSERT_NEAR(plastic.normal_force_n, yield_n, 1e-9 * yield_n) << z;
    ASSERT_LT(plastic.force_n.z(), elastic.force_n.z()) << z;
    ++flowing;
  }
  EXPECT_GT(flowing, 500);
  EXPECT_GT(elastic.force_n.z(), 2.0 * plastic.force_n.z());
  // The surface moved down with the flow: x0 sits below the face.
  EXPECT_LT(plastic.contact_origin_mm.z(), top - 1.0);
}

// Plastic loading is judged by the stress. A sideways stroke after a press kept the tool's
// velocity along N near zero, so under the velocity rule the stress climbed past sigma_f in
// the "unload" zone and one return mapping then dropped |F| by 10.7 % in a tick.
TEST(ContactPlasticity, ASidewaysPlasticStrokeHasNoSingleTickForceStep) {
  for (const double h : {1.0, 0.5}) {
    for (const double speed_mm_s : {2.0, 10.0}) {
      const int n = static_cast<int>(std::ceil(32.0 / h));
      const int top_k = static_cast<int>(std::ceil(6.0 / h));
      const DensityField field = energy_block(n, top_k, h);
      ToolForceOptions options = hertz_options(0.5);
      options.plastic.enabled = true;
      options.plastic.yield_stress_pa = 10e3;
      const ToolForceModel model(field, options);
      ToolForceState state = model.make_state();
      const double face_z = face_height_mm(top_k, h);
      const double step_mm = speed_mm_s * 1e-3;  // 1 kHz
      Vec3d x(8.0 + 0.37 * h, 0.5 * n * h - 0.21 * h, face_z + kToolRadiusMm + h);
      while (x.z() > face_z + kToolRadiusMm - 1.0) {  // 1 mm deep, well past the onset
        x.z() -= step_mm;
        model.step(x, state);
      }
      double largest_step = 0.0, previous = state.force_n.norm();
      int plastic_ticks = 0;
      // Level, with a hand's tremor of +-5 um (5 Hz) along the normal: the stroke moves in
      // and out of the material by turns, as a held tool does.
      const double level_z = x.z();
      int tick = 0;
      for (double travel = 0.0; travel < 8.0; travel += step_mm, ++tick) {
        x.x() += step_mm;
        x.z() = level_z + 0.005 * std::sin(2.0 * std::numbers::pi * 5.0 * tick * 1e-3);
        model.step(x, state);
        const double force = state.force_n.norm();
        if (travel > 0.5) {
          largest_step = std::max(largest_step, std::abs(force - previous) / previous);
        }
        plastic_ticks += state.zone == PlasticZone::kPlasticLoad;
        previous = force;
      }
      EXPECT_GT(plastic_ticks, 0) << h << " " << speed_mm_s;
      EXPECT_LE(largest_step, 0.01) << "h " << h << " mm, " << speed_mm_s << " mm/s";
      std::printf(
          "sideways plastic stroke, h %.1f mm, %.0f mm/s: largest step %.3f %%, %d "
          "plastic ticks\n",
          h, speed_mm_s, 100.0 * largest_step, plastic_ticks);
    }
  }
}

}  // namespace
}  // namespace hapvox::engine
