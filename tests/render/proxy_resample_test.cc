#include "render/proxy_resample.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cmath>
#include <functional>
#include <memory>

#include "engine/volume_io.h"
#include "render/suite_gl_context.h"
#include "render/tet_slicer.h"
#include "render/volume_renderer.h"

namespace hapvox::render {
namespace {

using Eigen::Vector3d;
using engine::fem::TetMesh;

// A cubic field of `n`^3 voxels of 1 mm with densities `rho` at voxel centres (world mm).
engine::DensityField field_of(int n, const std::function<double(const Vector3d&)>& rho) {
  engine::initialize_openvdb();
  auto grid = openvdb::FloatGrid::create(0.0f);
  auto access = grid->getAccessor();
  for (int z = 0; z < n; ++z) {
    for (int y = 0; y < n; ++y) {
      for (int x = 0; x < n; ++x) {
        const double value = rho(Vector3d(x, y, z));
        if (value > 0.0) access.setValue(openvdb::Coord(x, y, z), static_cast<float>(value));
      }
    }
  }
  return engine::DensityField(grid, Vector3d::Ones(), Vector3d::Zero(),
                              Eigen::Vector3i::Constant(n));
}

// Smooth material with structure in every direction: a ball with a dent and a rod.
double blob(const Vector3d& p, double n) {
  const Vector3d c = Vector3d::Constant(0.5 * (n - 1));
  const double ball = 0.32 * n - (p - c).norm();
  const double dent = (p - c - Vector3d(0.25 * n, 0.1 * n, 0.2 * n)).norm() - 0.15 * n;
  const double rod = 0.08 * n - Eigen::Vector2d(p.x() - 0.3 * n, p.z() - 0.6 * n).norm();
  const double signed_mm = std::max(std::min(ball, dent), rod);
  return std::clamp(0.5 + 0.4 * signed_mm, 0.0, 1.0) * (0.6 + 0.4 * p.z() / n);
}

// The lattice of `cells`^3 cubes over the voxel-centre box of an n^3 field.
TetMesh mesh_over(int n, int cells) {
  return engine::fem::regular_lattice({cells + 1, cells + 1, cells + 1}, (n - 1.0) / cells,
                                      Vector3d::Zero());
}

Eigen::VectorXd affine(const TetMesh& mesh, const Eigen::Matrix3d& a, const Vector3d& centre,
                       const Vector3d& shift) {
  Eigen::VectorXd u(3 * mesh.vertex_count());
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    const Vector3d x = mesh.rest_mm.col(v);
    u.segment<3>(3 * v) = centre + a * (x - centre) + shift - x;
  }
  return u;
}

struct Scene {
  int n;
  engine::DensityField field;
  DenseVolume dense;
  TetMesh mesh;
  explicit Scene(int n_voxels, int cells = 6)
      : n(n_voxels),
        field(field_of(n_voxels, [n_voxels](const Vector3d& p) { return blob(p, n_voxels); })),
        dense(dense_copy(field)),
        mesh(mesh_over(n_voxels, cells)) {}
  Vector3d centre() const { return Vector3d::Constant(0.5 * (n - 1)); }
};

TEST(ProxyResample, ResamplingEveryTetUndeformedGivesTheRestTexelsBitForBit) {
  const Scene scene(24);
  ResampleOptions options;
  options.motion_threshold_voxels = -1.0;  // every tet counts as moved
  ProxyResampler resampler(scene.dense, options);
  resampler.set_mesh(scene.mesh);
  const ResampleStats stats =
      resampler.update(Eigen::VectorXd::Zero(3 * scene.mesh.vertex_count()));
  EXPECT_EQ(stats.moved_tets, static_cast<std::size_t>(scene.mesh.tet_count()));
  EXPECT_EQ(stats.resampled_voxels, static_cast<std::size_t>(24 * 24 * 24));  // all covered
  EXPECT_EQ(stats.vacated_voxels, 0u);
  EXPECT_EQ(stats.changed_bricks, 27u);
  EXPECT_TRUE(resampler.texels() == resampler.rest_texels());
}

TEST(ProxyResample, AWholeVoxelShiftMovesEveryTexelAndEmptiesWhatTheMaterialLeft) {
  const Scene scene(24);
  ProxyResampler resampler(scene.dense);
  resampler.set_mesh(scene.mesh);
  resampler.update(affine(scene.mesh, Eigen::Matrix3d::Identity(), scene.centre(), {2, 0, 0}));
  const auto& out = resampler.texels();
  const auto& rest = resampler.rest_texels();
  int compared = 0;
  for (int z = 0; z < 24; ++z) {
    for (int y = 0; y < 24; ++y) {
      for (int x = 0; x < 24; ++x) {
        const std::size_t i = scene.dense.index(x, y, z) * 4;
        if (x < 2) {  // the material moved away from here
          ASSERT_EQ(out[i + 3], 0) << x << " " << y << " " << z;
          continue;
        }
        const std::size_t from = scene.dense.index(x - 2, y, z) * 4;
        for (int c = 0; c < 4; ++c)
          ASSERT_EQ(out[i + c], rest[from + c]) << x << " " << y << " " << z;
        ++compared;
      }
    }
  }
  EXPECT_EQ(compared, 22 * 24 * 24);
}

// A quarter turn about z through the centre maps voxel centres onto voxel centres: each texel
// is the rest texel turned back, its gradient direction turned (to one 8-bit step).
TEST(ProxyResample, AQuarterTurnMovesEachTexelToItsTurnedPlaceWithItsGradientTurned) {
  const Scene scene(24);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitZ()).toRotationMatrix();
  for (GradientTransform g :
       {GradientTransform::kVertexRotation, GradientTransform::kTetInverseTranspose}) {
    ResampleOptions options;
    options.gradient = g;
    ProxyResampler resampler(scene.dense, options);
    resampler.set_mesh(scene.mesh);
    resampler.update(affine(scene.mesh, r, scene.centre(), Vector3d::Zero()));
    const auto& out = resampler.texels();
    const auto& rest = resampler.rest_texels();
    for (int z = 0; z < 24; ++z) {
      for (int y = 0; y < 24; ++y) {
        for (int x = 0; x < 24; ++x) {
          // x = c + R (X - c): X = c + R^T (x - c); about z: (X, Y) = (y', -x') around c.
          const int rx = y, ry = 23 - x;
          const std::uint8_t* a = &out[scene.dense.index(x, y, z) * 4];
          const std::uint8_t* b = &rest[scene.dense.index(rx, ry, z) * 4];
          ASSERT_EQ(a[3], b[3]) << x << " " << y << " " << z;
          const Vector3d g_rest = Vector3d(b[0], b[1], b[2]) / 127.5 - Vector3d::Ones();
          const Vector3d g_out = Vector3d(a[0], a[1], a[2]) / 127.5 - Vector3d::Ones();
          ASSERT_LT((g_out - r * g_rest).cwiseAbs().maxCoeff(), 1.5 / 127.5)
              << gradient_transform_name(g) << " at " << x << " " << y << " " << z;
        }
      }
    }
  }
}

// The resample runs brick layers in parallel: one thread or many, the same texels, bit for
// bit, under a deformation whose tets cross layers and overlap (a twist and a bulge).
TEST(ProxyResample, ParallelLayersGiveWhatOneThreadGives) {
  const Scene scene(40, 5);
  Eigen::VectorXd u =
      affine(scene.mesh, Eigen::AngleAxisd(0.4, Vector3d(1, 2, 3).normalized()).toRotationMatrix(),
             scene.centre(), {1.5, -2.0, 3.0});
  for (int v = 0; v < scene.mesh.vertex_count(); ++v) {
    const Vector3d x = scene.mesh.rest_mm.col(v) - scene.centre();
    u.segment<3>(3 * v) += 4.0 * std::exp(-x.squaredNorm() / 100.0) * x.normalized();
  }
  for (GradientTransform g :
       {GradientTransform::kVertexRotation, GradientTransform::kTetInverseTranspose}) {
    ResampleOptions options;
    options.gradient = g;
    ProxyResampler serial(scene.dense, options), parallel(scene.dense, options);
    serial.set_mesh(scene.mesh);
    parallel.set_mesh(scene.mesh);
    ResampleStats one;
    {
      tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
      one = serial.update(u);
    }
    const ResampleStats many = parallel.update(u);
    EXPECT_EQ(one.resampled_voxels, many.resampled_voxels);
    EXPECT_EQ(one.vacated_voxels, many.vacated_voxels);
    EXPECT_GT(many.vacated_voxels, 0u);
    EXPECT_EQ(serial.changed_bricks(), parallel.changed_bricks());
    EXPECT_TRUE(serial.texels() == parallel.texels()) << gradient_transform_name(g);
  }
}

TEST(ProxyResample, UnmovedBricksStayBitIdenticalAndMovedOnesComeBackWhenTheMotionEnds) {
  const Scene scene(40, 10);
  ProxyResampler resampler(scene.dense);
  resampler.set_mesh(scene.mesh);
  // A bump: vertices within 8 mm of a point move 1.5 mm along x, fading out to zero there.
  const Vector3d at(12, 20, 20);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(3 * scene.mesh.vertex_count());
  for (int v = 0; v < scene.mesh.vertex_count(); ++v) {
    const double d = (scene.mesh.rest_mm.col(v) - at).norm();
    if (d < 8.0) u[3 * v] = 1.5 * (1.0 - d / 8.0);
  }
  const ResampleStats stats = resampler.update(u);
  EXPECT_GT(stats.resampled_voxels, 0u);
  const std::vector<std::uint32_t> changed = resampler.changed_bricks();
  const Eigen::Vector3i bricks = brick_counts(scene.dense.dims);
  EXPECT_LT(changed.size(), static_cast<std::size_t>(bricks.prod()) / 2);
  int unchanged = 0;
  bool any_differs = false;
  for (std::uint32_t b = 0; b < static_cast<std::uint32_t>(bricks.prod()); ++b) {
    const Eigen::Vector3i lo(b % bricks.x() * 8, b / bricks.x() % bricks.y() * 8,
                             b / (bricks.x() * bricks.y()) * 8);
    const bool listed = std::binary_search(changed.begin(), changed.end(), b);
    bool same = true;
    for (int z = lo.z(); z < std::min(lo.z() + 8, 40); ++z) {
      for (int y = lo.y(); y < std::min(lo.y() + 8, 40); ++y) {
        for (int x = lo.x(); x < std::min(lo.x() + 8, 40); ++x) {
          const std::size_t i = scene.dense.index(x, y, z) * 4;
          for (int c = 0; c < 4; ++c)
            same = same && resampler.texels()[i + c] == resampler.rest_texels()[i + c];
        }
      }
    }
    if (!listed) {
      ASSERT_TRUE(same) << "brick " << b << " changed but was not listed";
      ++unchanged;
    }
    any_differs = any_differs || !same;
  }
  EXPECT_TRUE(any_differs);
  EXPECT_GT(unchanged, 0);
  // The motion ends: everything is the rest again, and exactly those bricks are re-sent.
  const ResampleStats back = resampler.update(Eigen::VectorXd::Zero(u.size()));
  EXPECT_EQ(back.moved_tets, 0u);
  EXPECT_TRUE(resampler.texels() == resampler.rest_texels());
  EXPECT_EQ(resampler.changed_bricks(), changed);
}

// --- Through the renderer (EGL, Mesa's llvmpipe without a GPU) ---

struct Views {
  RenderSettings settings = [] {
    RenderSettings s;
    s.width = s.height = 160;
    s.draw_tool = false;
    return s;
  }();
};

Image render_with(VolumeRenderer& renderer, const OrbitCamera& camera, const RenderSettings& s) {
  return renderer.render(camera, ToolPose{}, s);
}

OrbitCamera camera_at(const Scene& scene, double azimuth_deg) {
  return OrbitCamera::framing(scene.field.world_min_mm(), scene.field.world_max_mm(), azimuth_deg,
                              25.0);
}

// A renderer of the scene with its texels resampled for displacement `u`.
std::unique_ptr<VolumeRenderer> deformed(const Scene& scene, const ResampleOptions& options,
                                         const Eigen::VectorXd& u) {
  suite_gl_context();
  auto renderer =
      std::make_unique<VolumeRenderer>(scene.field, TransferFunction::from_spec("clay"));
  ProxyResampler resampler(scene.dense, options);
  resampler.set_mesh(scene.mesh);
  resampler.update(u);
  renderer->replace_texels(resampler.texels(), resampler.changed_bricks());
  return renderer;
}

TEST(ProxyRender, AnUndeformedResampleDrawsWhatTodaysRendererDraws) {
  const Scene scene(32);
  suite_gl_context();
  VolumeRenderer plain(scene.field, TransferFunction::from_spec("clay"));
  ResampleOptions options;
  options.motion_threshold_voxels = -1.0;  // every tet resampled
  const auto proxy = deformed(scene, options, Eigen::VectorXd::Zero(3 * scene.mesh.vertex_count()));
  const Views v;
  EXPECT_GE(psnr_db(render_with(plain, camera_at(scene, 30), v.settings),
                    render_with(*proxy, camera_at(scene, 30), v.settings)),
            50.0);
}

// The block hybrid (render/tet_slicer.h): plain polygons where nothing moved, the deformed
// tets sliced elsewhere, over the rest texels.
std::unique_ptr<VolumeRenderer> sliced(const Scene& scene, const Eigen::VectorXd& u,
                                       TetSlicer& slicer, TetSliceStats& stats) {
  suite_gl_context();
  auto renderer =
      std::make_unique<VolumeRenderer>(scene.field, TransferFunction::from_spec("clay"));
  slicer.set_mesh(scene.mesh);
  stats = slicer.set_displacement(u, 1.0 / 512.0);
  renderer->set_slice_builder(
      [&slicer](const Vector3d& lo, const Vector3d& hi, const Vector3d& view, int slices,
                SliceMesh& mesh) { slicer.build(lo, hi, view, slices, mesh); });
  return renderer;
}

TEST(TetSlicer, AtRestTheBlocksPlainPolygonsDrawTodaysImage) {
  const Scene scene(32);
  suite_gl_context();
  VolumeRenderer plain(scene.field, TransferFunction::from_spec("clay"));
  TetSlicer slicer(scene.field.world_min_mm(), scene.field.world_max_mm(), scene.field.dims(), 8);
  TetSliceStats stats;
  const auto hybrid =
      sliced(scene, Eigen::VectorXd::Zero(3 * scene.mesh.vertex_count()), slicer, stats);
  EXPECT_EQ(stats.deformed_blocks, 0u);
  EXPECT_EQ(stats.sliced_tets, 0u);
  const Views v;
  const double db = psnr_db(render_with(plain, camera_at(scene, 30), v.settings),
                            render_with(*hybrid, camera_at(scene, 30), v.settings));
  std::printf("[ measured ] block hybrid at rest vs today's slices: %.1f dB\n", db);
  EXPECT_GE(db, 50.0);
}

TEST(TetSlicer, ALocalBumpDrawsWhereTheResampledVolumeHasItsMaterial) {
  const Scene scene(32);
  // A smooth bump: vertices within 12 mm of a point above the centre move up to 3 mm.
  const Vector3d at = scene.centre() + Vector3d(4, 0, 6);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(3 * scene.mesh.vertex_count());
  for (int v = 0; v < scene.mesh.vertex_count(); ++v) {
    const double q = (scene.mesh.rest_mm.col(v) - at).norm() / 12.0;
    if (q < 1.0) u.segment<3>(3 * v) = std::pow(1 - q, 4) * (4 * q + 1) * Vector3d(2, 0, 2.2);
  }
  TetSlicer slicer(scene.field.world_min_mm(), scene.field.world_max_mm(), scene.field.dims(), 8);
  TetSliceStats stats;
  const auto hybrid = sliced(scene, u, slicer, stats);
  EXPECT_GT(stats.deformed_blocks, 0u);
  EXPECT_LT(stats.deformed_blocks, 64u);  // a hybrid: some blocks stay plain
  const auto resampled = deformed(scene, {}, u);
  VolumeRenderer plain(scene.field, TransferFunction::from_spec("clay"));
  const Views v;
  const Image a = render_with(*hybrid, camera_at(scene, 30), v.settings);
  const Image b = render_with(*resampled, camera_at(scene, 30), v.settings);
  const Image rest = render_with(plain, camera_at(scene, 30), v.settings);
  // Where the bump changed the picture (the resampled frame differs from the rest one by
  // more than 24 levels in a channel), the hybrid's pixels are much nearer the resampled
  // frame's than the rest frame's are.
  double hybrid_error = 0, rest_error = 0;
  int changed = 0;
  for (std::size_t i = 0; i < b.rgba.size(); ++i) {
    if (std::abs(int(b.rgba[i]) - int(rest.rgba[i])) <= 24) continue;
    ++changed;
    hybrid_error += std::abs(int(a.rgba[i]) - int(b.rgba[i]));
    rest_error += std::abs(int(rest.rgba[i]) - int(b.rgba[i]));
  }
  ASSERT_GT(changed, 200);
  hybrid_error /= changed;
  rest_error /= changed;
  std::printf(
      "[ measured ] block hybrid vs resampled: %.1f dB; where the bump changed the "
      "picture (%d values) |hybrid - resampled| %.1f, |rest - resampled| %.1f\n",
      psnr_db(a, b), changed, hybrid_error, rest_error);
  EXPECT_GE(psnr_db(a, b), 35.0);
  EXPECT_LT(hybrid_error, 0.5 * rest_error);
}

// An affine map x = c + A (X - c) + b on the mesh, against the field resampled analytically at
// every voxel centre (rho(A^-1 (x - c - b) + c), trilinear) and drawn by today's renderer.
TEST(ProxyRender, AnAffineDeformationMatchesAnAnalyticResample) {
  const int n = 32;
  const Scene scene(n);
  Eigen::Matrix3d a;
  a << 1.0, 0.12, 0.0, 0.0, 0.95, 0.05, -0.08, 0.0, 1.05;
  a = Eigen::AngleAxisd(0.3, Vector3d(0.2, 0.3, 1).normalized()).toRotationMatrix() * a;
  const Vector3d shift(0.7, -0.4, 0.3);
  const Eigen::Matrix3d inverse = a.inverse();
  const engine::DensityField analytic = field_of(n, [&](const Vector3d& x) {
    const Vector3d rest = scene.centre() + inverse * (x - scene.centre() - shift);
    // Trilinear in the rest field, clamped at its faces as the texture is.
    const Vector3d s = rest.cwiseMax(Vector3d::Zero()).cwiseMin(Vector3d::Constant(n - 1));
    if ((rest - s).norm() > 0.5) return 0.0;  // outside the mesh: nothing there any more
    const Eigen::Vector3i i0 = s.array().floor().cast<int>().min(n - 2);
    const Vector3d f = s - i0.cast<double>();
    double value = 0.0;
    for (int k = 0; k < 8; ++k) {
      const Eigen::Vector3i c = i0 + Eigen::Vector3i(k & 1, (k >> 1) & 1, (k >> 2) & 1);
      double w = 1.0;
      for (int d = 0; d < 3; ++d) w *= c[d] == i0[d] ? 1.0 - f[d] : f[d];
      value += w * scene.dense.density[scene.dense.index(c.x(), c.y(), c.z())];
    }
    return value;
  });
  suite_gl_context();
  VolumeRenderer reference(analytic, TransferFunction::from_spec("clay"));
  const Views v;
  const Image expected = render_with(reference, camera_at(scene, 30), v.settings);
  for (GradientTransform g :
       {GradientTransform::kVertexRotation, GradientTransform::kTetInverseTranspose}) {
    ResampleOptions options;
    options.gradient = g;
    const auto proxy = deformed(scene, options, affine(scene.mesh, a, scene.centre(), shift));
    const double db = psnr_db(expected, render_with(*proxy, camera_at(scene, 30), v.settings));
    std::printf("affine, %s: %.1f dB\n", gradient_transform_name(g), db);
    EXPECT_GE(db, 40.0) << gradient_transform_name(g);
  }
}

// The volume turned a quarter about z on the mesh, seen from a camera turned with it, is the
// still seen from where the camera was: shading turns with the material.
TEST(ProxyRender, ARigidQuarterTurnSeenFromATurnedCameraIsTheStill) {
  const Scene scene(32);
  suite_gl_context();
  VolumeRenderer still(scene.field, TransferFunction::from_spec("clay"));
  const Eigen::Matrix3d r = Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitZ()).toRotationMatrix();
  const auto turned = deformed(scene, {}, affine(scene.mesh, r, scene.centre(), Vector3d::Zero()));
  const Views v;
  const Image before = render_with(still, camera_at(scene, 30), v.settings);
  const Image after = render_with(*turned, camera_at(scene, 120), v.settings);
  const Image unturned_view = render_with(*turned, camera_at(scene, 30), v.settings);
  const double db = psnr_db(before, after);
  std::printf("quarter turn: %.1f dB against the still; %.1f dB from the unturned camera\n", db,
              psnr_db(before, unturned_view));
  EXPECT_GE(db, 40.0);
  EXPECT_LT(psnr_db(before, unturned_view), 30.0);  // the turn itself is visible
}

}  // namespace
}  // namespace hapvox::render
