#include "engine/tool_force.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <random>

#include "engine/block_field.h"
#include "engine/errors.h"
#include "engine/relax.h"
#include "engine/volume_io.h"

namespace hapvox::engine {
namespace {

using fixtures::make_block;

// A solid sphere of radius r_mm centred at c_mm.
DensityField make_ball(int n, double voxel_mm, const Vec3d& c_mm, double r_mm) {
  initialize_openvdb();
  auto grid = openvdb::FloatGrid::create(0.0f);
  auto acc = grid->getAccessor();
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k)
        if ((Vec3d(i, j, k) * voxel_mm - c_mm).norm() <= r_mm) acc.setValueOn({i, j, k}, 1.0f);
  return DensityField(grid, Vec3d::Constant(voxel_mm), Vec3d::Zero(), Vec3i(n, n, n));
}

ToolForceOptions options_for(double diameter_mm, double e_pa = 200e3, double nu = 0.3) {
  ToolForceOptions o;
  o.contact_law = ContactLaw::kPaper;  // this file: the seed's law, L = R (closed forms)
  o.tool.diameter_mm = diameter_mm;
  o.material.youngs_modulus_pa = e_pa;
  o.material.poisson_ratio = nu;
  return o;
}

// docs/physics.md, "Sphere on a flat block": force for a tool whose lowest point is
// depth_mm below the block's face (its nominal surface, where contact starts), with
// trilinear sampling of voxel size h.
double closed_form_block_force_n(const ToolForceModel& model, double depth_mm, double h_mm) {
  const double r = model.tool_radius_mm();
  const double area =
      std::numbers::pi * (2.0 * r * depth_mm - depth_mm * depth_mm - h_mm * h_mm / 12.0);
  const double strain = depth_mm / model.fixed_reference_length_mm();
  return (model.lame().lambda_pa + 2.0 * model.lame().mu_pa) * strain * area * 1e-6;
}

TEST(ToolForce, ZeroOutOfContact) {
  const DensityField field = make_block(48, 24, Vec3d::Constant(0.5));
  const ToolForceModel model(field, options_for(8.0));
  ToolForceState state = model.make_state();
  const double face_z = 23.5 * 0.5;
  // Gaps below 0.25 mm (half a voxel) put the tool in the density ramp above the face:
  // some density, but not yet the nominal surface.
  for (double gap : {5.0, 1.0, 0.3, 0.2, 0.1, 0.01}) {
    model.step(Vec3d(12.1, 11.7, face_z + 4.0 + gap), state);
    EXPECT_FALSE(state.in_contact) << gap;
    EXPECT_EQ(state.force_n, Vec3d::Zero()) << gap;
  }
  // Far outside the volume's active box too.
  model.step(Vec3d(-100, -100, -100), state);
  EXPECT_EQ(state.force_n, Vec3d::Zero());
}

TEST(ToolForce, SphereOnBlockMatchesClosedForm) {
  const double h = 0.5;
  const DensityField field = make_block(64, 32, Vec3d::Constant(h));
  ToolForceOptions options = options_for(10.0);
  options.sample_spacing_voxels = 0.5;
  options.max_surface_samples = 20000;
  const ToolForceModel model(field, options);
  ToolForceState state = model.make_state();
  const double face_z = 31.5 * h;
  const double r = model.tool_radius_mm();
  const Vec3d xy(16.13, 15.87, 0.0);  // off the voxel lattice on purpose
  // Slow press from above: 2 um per tick.
  double checked = 0;
  for (double z = face_z + r + 1.0; z > face_z + r - 0.5 * r; z -= 0.002) {
    model.step(xy + Vec3d(0, 0, z), state);
    const double depth = face_z + r - z;
    if (depth >= 2.0 * h) {
      const double expected = closed_form_block_force_n(model, depth, h);
      ASSERT_NEAR(state.force_n.z(), expected, 0.02 * expected) << "depth " << depth;
      EXPECT_LT(std::hypot(state.force_n.x(), state.force_n.y()), 0.01 * expected);
      ++checked;
    }
  }
  EXPECT_GT(checked, 100);
}

TEST(ToolForce, LinearInDisplacementAtFixedContact) {
  const DensityField field = make_block(48, 24, Vec3d::Constant(0.5));
  const ToolForceModel model(field, options_for(8.0));
  ToolForceState state = model.make_state();
  const Vec3d p(12.0, 12.0, 23.5 * 0.5 + 4.0 - 1.0);
  const ContactIntegral contact = model.integrate_contact(p, state);
  ASSERT_GT(contact.samples_in_contact, 0);
  const Vec3d u(0.1, -0.05, -0.4);
  const double length = model.fixed_reference_length_mm();
  ASSERT_EQ(length, 4.0);  // the paper's L = R
  const Vec3d f1 = ToolForceModel::traction_force_n(model.stress_pa(u, length), contact);
  for (double scale : {0.25, 0.5, 2.0, 3.0, 10.0}) {
    const Vec3d fs = ToolForceModel::traction_force_n(model.stress_pa(scale * u, length), contact);
    EXPECT_LT((fs - scale * f1).norm(), 1e-12 * fs.norm()) << scale;
  }
}

TEST(ToolForce, ProportionalToYoungsModulus) {
  const DensityField field = make_block(48, 24, Vec3d::Constant(0.5));
  const ToolForceModel soft(field, options_for(8.0, 100e3));
  const ToolForceModel stiff(field, options_for(8.0, 370e3));
  ToolForceState a = soft.make_state();
  ToolForceState b = stiff.make_state();
  for (double z = 20.0; z > 14.0; z -= 0.01) {
    const Vec3d p(12.3, 11.9, z);
    soft.step(p, a);
    stiff.step(p, b);
    EXPECT_LE((b.force_n - 3.7 * a.force_n).norm(), 1e-9 * b.force_n.norm());
  }
  EXPECT_GT(b.force_n.norm(), 0.0);
}

TEST(ToolForce, PointsOutOfTheMaterial) {
  const double r_ball = 12.0;
  const Vec3d centre(16.0, 16.0, 16.0);
  const DensityField field = make_ball(64, 0.5, centre, r_ball);
  const ToolForceModel model(field, options_for(6.0));
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  for (int trial = 0; trial < 12; ++trial) {
    const Vec3d dir = Vec3d(normal(rng), normal(rng), normal(rng)).normalized();
    ToolForceState state = model.make_state();
    // Approach the ball's centre along -dir until 1.5 mm past first contact.
    double first_contact = -1.0;
    for (double s = r_ball + 6.0; s > r_ball - 2.0; s -= 0.01) {
      model.step(centre + s * dir, state);
      if (state.in_contact && first_contact < 0) first_contact = s;
      if (first_contact > 0 && first_contact - s >= 1.5) break;
    }
    ASSERT_GT(state.force_n.norm(), 0.0);
    const double cos_angle = state.force_n.normalized().dot(dir);
    EXPECT_GT(cos_angle, std::cos(2.0 * std::numbers::pi / 180.0)) << "trial " << trial;
  }
}

TEST(ToolForce, NoJumpOnSlowConstantSpeedPress) {
  const DensityField field = make_block(48, 24, Vec3d::Constant(0.5));
  const ToolForceModel model(field, options_for(8.0));
  ToolForceState state = model.make_state();
  // 10 mm/s at 1 kHz, slightly oblique so the tool crosses voxel boundaries on all axes.
  const Vec3d start(11.0, 11.0, 18.0);
  const Vec3d velocity = Vec3d(0.7, 0.4, -10.0);
  std::vector<Vec3d> forces;
  for (int tick = 0; tick <= 500; ++tick) {
    model.step(start + velocity * (tick * 1e-3), state);
    forces.push_back(state.force_n);
  }
  double peak = 0.0;
  double max_jump = 0.0;
  for (std::size_t i = 1; i < forces.size(); ++i) {
    peak = std::max(peak, forces[i].norm());
    max_jump = std::max(max_jump, (forces[i] - forces[i - 1]).norm());
  }
  ASSERT_GT(peak, 0.1);
  EXPECT_LT(max_jump, 0.02 * peak) << "peak " << peak;
}

TEST(ToolForce, SlidingForceIsBoundedByTheSlipRatioAndOpposesMotion) {
  const DensityField field = make_block(96, 24, Vec3d::Constant(0.5));
  auto slide = [&](double slip_ratio) {
    ToolForceOptions options = options_for(8.0);
    options.friction_coefficient = slip_ratio;
    const ToolForceModel model(field, options);
    ToolForceState state = model.make_state();
    const double z_pressed = 23.5 * 0.5 + 4.0 - 1.0;  // 1 mm into the face
    for (double z = z_pressed + 2.0; z > z_pressed; z -= 0.01) model.step(Vec3d(8, 24, z), state);
    std::vector<Vec3d> forces;
    for (double x = 8.0; x <= 38.0; x += 0.01) {
      model.step(Vec3d(x, 24, z_pressed), state);
      forces.push_back(state.force_n);
    }
    return forces;
  };
  const std::vector<Vec3d> slipping = slide(0.5);
  const std::vector<Vec3d> sticking = slide(INFINITY);
  // Steady sliding: the force after 10 mm equals the force after 30 mm.
  EXPECT_LT((slipping.back() - slipping[1000]).norm(), 0.01 * slipping.back().norm());
  // Tangential force opposes the motion (+x) and stays within the slip limit.
  EXPECT_LT(slipping.back().x(), 0.0);
  EXPECT_GT(slipping.back().z(), 0.0);
  // The paper's fixed x0 keeps loading the spring as the tool slides.
  EXPECT_GT(sticking.back().norm(), 3.0 * slipping.back().norm());
}

// Slope of stress over strain by least squares over the points of one zone.
double fitted_slope(const std::vector<std::pair<double, double>>& points) {
  double mx = 0, my = 0;
  for (const auto& [x, y] : points) mx += x, my += y;
  mx /= points.size();
  my /= points.size();
  double sxy = 0, sxx = 0;
  for (const auto& [x, y] : points) sxy += (x - mx) * (y - my), sxx += (x - mx) * (x - mx);
  return sxy / sxx;
}

struct PathRecord {
  std::vector<std::pair<double, double>> elastic, load, unload, reload_elastic;
  double first_yield_pa = -1, reload_yield_pa = -1, unload_start_pa = -1;
  int surface_changes = 0;
  Vec3d origin_after_unload = Vec3d::Zero();
};

// Press 2 mm into a block, back off 0.6 mm, press again to 2.5 mm.
PathRecord press_release_press(double e_ep_pa) {
  static const DensityField field = make_block(48, 24, Vec3d::Constant(0.5));
  ToolForceOptions options = options_for(8.0, 200e3);
  options.plastic.enabled = true;
  options.plastic.yield_stress_pa = 30e3;
  options.plastic.elastoplastic_modulus_pa = e_ep_pa;
  const ToolForceModel model(field, options);
  ToolForceState state = model.make_state();
  const double top = 23.5 * 0.5 + 4.0;  // tool centre at first contact (the nominal surface)
  std::vector<double> path;
  for (double z = top + 1.0; z > top - 2.0; z -= 0.002) path.push_back(z);
  for (double z = top - 2.0; z < top - 1.4; z += 0.002) path.push_back(z);
  for (double z = top - 1.4; z > top - 2.5; z -= 0.002) path.push_back(z);
  PathRecord r;
  int phase = 0;  // 0 first load, 1 unload, 2 reload
  for (std::size_t i = 0; i < path.size(); ++i) {
    if (i > 0 && phase == 0 && path[i] > path[i - 1]) phase = 1;
    if (i > 0 && phase == 1 && path[i] < path[i - 1]) {
      phase = 2;
      r.origin_after_unload = state.contact_origin_mm;
    }
    model.step(Vec3d(12.1, 11.9, path[i]), state);
    r.surface_changes += state.surface_change_emitted;
    const std::pair<double, double> point(state.strain, state.stress_measure_pa);
    if (state.zone == PlasticZone::kElastic && phase == 0 && state.strain > 0) {
      r.elastic.push_back(point);
    } else if (state.zone == PlasticZone::kPlasticLoad) {
      if (phase == 0 && r.first_yield_pa < 0) r.first_yield_pa = state.stress_measure_pa;
      if (phase == 2 && r.reload_yield_pa < 0) r.reload_yield_pa = state.stress_measure_pa;
      if (phase == 0) r.load.push_back(point);
    } else if (state.zone == PlasticZone::kPlasticUnload) {
      if (r.unload_start_pa < 0) r.unload_start_pa = r.load.back().second;
      (phase == 1 ? r.unload : r.reload_elastic).push_back(point);
    }
  }
  return r;
}

TEST(ToolForce, PlasticPathShowsTheThreeSlopesAndTheYield) {
  const double e = 200e3;
  for (double e_ep : {0.0, 40e3}) {
    const PathRecord r = press_release_press(e_ep);
    ASSERT_GT(r.elastic.size(), 20u);
    ASSERT_GT(r.load.size(), 20u);
    ASSERT_GT(r.unload.size(), 20u);
    EXPECT_NEAR(fitted_slope(r.elastic), e, 0.02 * e) << e_ep;
    if (e_ep > 0) {
      EXPECT_NEAR(fitted_slope(r.load), e_ep, 0.02 * e_ep);
    } else {
      EXPECT_NEAR(fitted_slope(r.load), 0.0, 0.001 * e);  // perfectly plastic: flat
    }
    EXPECT_NEAR(fitted_slope(r.unload), e, 0.02 * e) << e_ep;
    EXPECT_NEAR(fitted_slope(r.reload_elastic), e, 0.02 * e) << e_ep;
    // Yield at sigma_f; on reload at the stress reached before unloading (hardened).
    EXPECT_NEAR(r.first_yield_pa, 30e3, 0.02 * 30e3) << e_ep;
    EXPECT_NEAR(r.reload_yield_pa, r.unload_start_pa, 0.02 * r.unload_start_pa) << e_ep;
    // Hardening: sigma_f + E_ep x (strain at unload 2 mm / 4 mm - strain at yield).
    const double yield_strain = 30e3 / e;
    EXPECT_NEAR(r.reload_yield_pa, 30e3 + e_ep * (0.5 - yield_strain), 0.02 * 30e3) << e_ep;
    // Plastic ticks asked for surface changes; the surface moved down for good.
    EXPECT_GE(r.surface_changes, static_cast<int>(r.load.size()));
    EXPECT_GT(r.surface_changes, 100);
    EXPECT_LT(r.origin_after_unload.z(), 23.5 * 0.5 + 4.0 - 0.5);
  }
}

TEST(ToolForce, FarAwayPositionsGiveZeroForceEvenWithoutBounds) {
  // Plastic models skip the bounding-box early-out; absurd positions must still be safe.
  const DensityField field = make_block(16, 8, Vec3d::Constant(1.0));
  ToolForceOptions o = options_for(4.0, 1e5);
  o.plastic.enabled = true;
  const ToolForceModel model(field, o);
  ToolForceState state = model.make_state();
  for (const Vec3d& p : {Vec3d(1e12, 0, 0), Vec3d(-3e9, 4e9, 0), Vec3d(0, 0, -1e300)}) {
    model.step(p, state);
    EXPECT_EQ(state.force_n, Vec3d::Zero());
    EXPECT_FALSE(state.in_contact);
  }
}

TEST(ToolForce, RejectsNonsensePlasticMaterial) {
  const DensityField field = make_block(16, 8, Vec3d::Constant(1.0));
  ToolForceOptions o = options_for(4.0, 1e5);
  o.plastic.enabled = true;
  o.plastic.yield_stress_pa = 0.0;
  EXPECT_THROW(ToolForceModel(field, o), InputError);
  o.plastic.yield_stress_pa = 1e4;
  o.plastic.elastoplastic_modulus_pa = 1e5;  // = E
  try {
    ToolForceModel model(field, o);
    FAIL();
  } catch (const InputError& error) {
    EXPECT_STREQ(error.what(),
                 "material: elasto-plastic modulus must lie in [0, E), got 100000 Pa");
  }
}

TEST(ToolForce, DeterministicAcrossRuns) {
  const DensityField field = make_block(48, 24, Vec3d::Constant(0.5));
  const ToolForceModel model(field, options_for(8.0));
  auto run = [&] {
    ToolForceState state = model.make_state();
    std::vector<Vec3d> out;
    for (int tick = 0; tick < 800; ++tick) {
      const double t = tick * 1e-3;
      model.step(Vec3d(12 + 2 * std::sin(3 * t), 12 + std::cos(5 * t), 18 - 8 * t), state);
      out.push_back(state.force_n);
    }
    return out;
  };
  EXPECT_EQ(run(), run());
}

// Issue 29, point 2: the force path reads through a leaf window and stencils kept between
// ticks; with them off (use_read_caches = false) it reads every point through the
// accessor, as before. The forces must be the same bits: pressing and sliding on a block
// (unit voxels, and anisotropic ones in a turned, offset frame), elastic and plastic, the
// plastic stroke's deletions changing the field under the tool as it goes.
TEST(ToolForce, ReadCachesGiveBitIdenticalForcesOnPressesSlidesAndAPlasticStroke) {
  const DensityField block = generate_volume("block:dims=48");  // face at index z = 23.5
  const Mat3d turned = Eigen::AngleAxisd(0.3, Vec3d(1, 2, 3).normalized()).toRotationMatrix();
  for (const bool plastic : {false, true}) {
    for (const bool skewed : {false, true}) {
      DensityField field(block.grid().deepCopy(),
                         skewed ? Vec3d(0.6, 0.8, 0.5) : Vec3d::Constant(1.0),
                         skewed ? Vec3d(3, -2, 1) : Vec3d::Zero(), block.dims(),
                         skewed ? turned : Mat3d::Identity());
      ToolForceOptions options;  // the Hertz law
      options.tool.diameter_mm = 8.0;
      options.plastic.enabled = plastic;
      const ToolForceModel model(field, options);
      ToolForceState cached = model.make_state();
      ToolForceState direct = model.make_state();
      direct.use_read_caches = false;
      MassGrid mass(field);
      const double radius_z = 4.0 / field.voxel_size_mm().z();  // in index units
      int in_contact = 0, events = 0;
      for (int tick = 0; tick < 1500; ++tick) {
        // Down from 1 voxel above the face to a third of the radius deep, then 30 voxels
        // along x (out of the leaf window the press began in), weaving in y.
        const double down = std::min(tick, 500) * (1.0 + radius_z / 3.0) / 500.0;
        const double along = std::max(tick - 500, 0) * 0.03;
        const Vec3d at_index(10.0 + along, 24.0 + 0.8 * std::sin(along), 24.5 + radius_z - down);
        const Vec3d at = field.index_to_world(at_index);
        model.step(at, cached);
        model.step(at, direct);
        ASSERT_TRUE(cached.force_n == direct.force_n)
            << "tick " << tick << ": " << cached.force_n.transpose() << " vs "
            << direct.force_n.transpose();
        ASSERT_EQ(cached.surface_change_emitted, direct.surface_change_emitted) << tick;
        in_contact += cached.in_contact;
        if (cached.surface_change_emitted) {
          ++events;
          mass.apply_deletion(cached.surface_change);
          mass.relax(200);
          if (mass.publish_changes(field) > 0) {
            cached.invalidate_cache();
            direct.invalidate_cache();
          }
        }
      }
      EXPECT_GT(in_contact, 1000);
      EXPECT_EQ(events > 100, plastic) << events << " plastic events";
      EXPECT_GT(cached.window.rebuilds(), 1u);  // the window followed the tool
      EXPECT_EQ(direct.window.rebuilds(), 0u);  // and the reference never used one
    }
  }
}

TEST(ToolForce, NaiveBaselineAgreesWithSurfaceQuadrature) {
  const DensityField field = make_block(64, 32, Vec3d::Constant(0.5));
  const ToolForceModel model(field, options_for(16.0));
  ToolForceState state = model.make_state();
  const Vec3d p(16.2, 15.9, 31.5 * 0.5 + 8.0 - 3.0);
  const ContactIntegral fast = model.integrate_contact(p, state);
  const ContactIntegral naive = model.integrate_contact_naive(p, state);
  ASSERT_GT(fast.area_vector_mm2.norm(), 0.0);
  EXPECT_NEAR(naive.area_vector_mm2.z(), fast.area_vector_mm2.z(),
              0.1 * std::abs(fast.area_vector_mm2.z()));
}

TEST(ToolForce, AnisotropicVoxelsMatchTheClosedForm) {
  // Thin z voxels (0.25 mm) under 0.5 mm x/y voxels: the tool is an ellipsoid in index
  // space, the force must still be the sphere's, with the ramp width of the z spacing.
  const double hz = 0.25;
  const DensityField field = make_block(48, 48, Vec3d(0.5, 0.5, hz));
  ToolForceOptions options = options_for(8.0);
  options.sample_spacing_voxels = 0.5;
  options.max_surface_samples = 20000;
  const ToolForceModel model(field, options);
  ToolForceState state = model.make_state();
  const double face_z = 47.5 * hz;
  for (int tick = 0; tick < 700; ++tick) {
    const double depth = -5.0 + tick * 0.01;
    model.step(Vec3d(12.1, 12.2, face_z + 4.0 - depth), state);
    if (depth >= 2 * hz) {
      const double expected = closed_form_block_force_n(model, depth, hz);
      ASSERT_NEAR(state.force_n.z(), expected, 0.02 * expected) << "depth " << depth;
    }
  }
}

TEST(ToolForce, RejectsNonsenseMaterialAndTool) {
  const DensityField field = make_block(16, 8, Vec3d::Constant(1.0));
  auto message = [&](ToolForceOptions o) {
    try {
      ToolForceModel model(field, o);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message(options_for(4.0, 0.0)),
            "material: Young's modulus must be positive and finite, got 0 Pa");
  EXPECT_EQ(message(options_for(4.0, -5.0)),
            "material: Young's modulus must be positive and finite, got -5 Pa");
  EXPECT_EQ(message(options_for(4.0, 1e5, 0.5)),
            "material: Poisson's ratio must lie in (-1, 0.5), got 0.5");
  EXPECT_EQ(message(options_for(4.0, 1e5, -1.0)),
            "material: Poisson's ratio must lie in (-1, 0.5), got -1");
  EXPECT_EQ(message(options_for(4.0, 1e5, NAN)),
            "material: Poisson's ratio must lie in (-1, 0.5), got nan");
  EXPECT_EQ(message(options_for(0.0)), "tool: tool diameter must be positive and finite, got 0 mm");
}

TEST(ToolForce, ATurnedGridGivesTheTurnedForce) {
  // The same block, its grid turned in the world: pressing its (turned) top face along the
  // turned normal gives the same force, turned. Computed in world: without the turn the force
  // would come out along the grid's z.
  const DensityField plain = make_block(48, 24, Vec3d::Constant(0.5));
  const Mat3d turn = Eigen::AngleAxisd(0.6, Vec3d(1, 0.5, -0.3).normalized()).toRotationMatrix();
  const DensityField turned(plain.grid().deepCopy(), plain.voxel_size_mm(), plain.origin_mm(),
                            plain.dims(), turn);
  const ToolForceModel model_plain(plain, options_for(8.0));
  const ToolForceModel model_turned(turned, options_for(8.0));
  ToolForceState a = model_plain.make_state();
  ToolForceState b = model_turned.make_state();
  const double face_z = 23.5 * 0.5;
  for (int tick = 0; tick <= 400; ++tick) {
    const Vec3d p(12.1, 11.9, face_z + 4.0 + 2.0 - tick * 0.01);  // 2 mm deep at the end
    model_plain.step(p, a);
    model_turned.step(turned.grid_to_world(p), b);
  }
  ASSERT_GT(a.force_n.norm(), 0.0);
  EXPECT_NEAR(b.force_n.norm(), a.force_n.norm(), 0.01 * a.force_n.norm());
  const double cos_angle = b.force_n.normalized().dot(turn * Vec3d::UnitZ());
  EXPECT_GT(cos_angle, std::cos(1.0 * std::numbers::pi / 180.0));
}

}  // namespace
}  // namespace hapvox::engine
