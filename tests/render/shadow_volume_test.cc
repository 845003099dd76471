#include "render/shadow_volume.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <functional>

#include "engine/density_field.h"
#include "engine/fem/tet_mesh.h"
#include "render/gl_context.h"
#include "render/proxy_resample.h"
#include "render/texels.h"
#include "render/volume_renderer.h"

namespace hapvox::render {
namespace {

// RGBA8 texels of a dims box whose density byte is `density(x, y, z)`.
std::vector<std::uint8_t> texels_of(const Eigen::Vector3i& dims,
                                    const std::function<int(int, int, int)>& density) {
  std::vector<std::uint8_t> texels(static_cast<std::size_t>(dims.prod()) * 4, 128);
  for (int z = 0; z < dims.z(); ++z) {
    for (int y = 0; y < dims.y(); ++y) {
      for (int x = 0; x < dims.x(); ++x) {
        texels[((static_cast<std::size_t>(z) * dims.y() + y) * dims.x() + x) * 4 + 3] =
            static_cast<std::uint8_t>(density(x, y, z));
      }
    }
  }
  return texels;
}

// Opacity a at density byte 255, none elsewhere.
std::array<float, 256> opacity_of_full(float a) {
  std::array<float, 256> opacity{};
  opacity[255] = a;
  return opacity;
}

// A slab over the whole width: every column the same, so the blur changes nothing and T is
// Beer-Lambert's product, (1 - a)^(voxels above) inside and (1 - a)^depth below.
TEST(ShadowVolume, UnderAUniformSlabTheLightFallsAsTheProductOfWhatLiesAbove) {
  const Eigen::Vector3i dims(16, 16, 32);
  const float a = 0.2f;
  ShadowVolume shadow(dims, 2);
  shadow.update(texels_of(dims, [](int, int, int z) { return z >= 16 ? 255 : 0; }),
                opacity_of_full(a));
  for (int z = 0; z < dims.z(); ++z) {
    const double expected = z >= 16 ? std::pow(1.0 - a, 31 - z) : std::pow(1.0 - a, 16.0);
    for (int x : {0, 7, 15}) {
      EXPECT_NEAR(shadow.at(x, 5, z), expected, 0.5 / 255 + 1e-6) << "z " << z << " x " << x;
    }
  }
}

// An opaque plate over x < 8 at the top: below it, dark; beyond it, lit; between, the box
// blur's penumbra, the lit share of the 5 columns x-2..x+2.
TEST(ShadowVolume, AnOpaquePlatesShadowHasAPenumbraAsWideAsTheBlur) {
  const Eigen::Vector3i dims(24, 8, 16);
  ShadowVolume shadow(dims, 2);
  shadow.update(texels_of(dims, [](int x, int, int z) { return x < 8 && z == 15 ? 255 : 0; }),
                opacity_of_full(1.0f));
  for (int x = 0; x < dims.x(); ++x) {
    int lit = 0;  // below the plate
    for (int k = x - 2; k <= x + 2; ++k) lit += std::clamp(k, 0, dims.x() - 1) >= 8 ? 1 : 0;
    for (int z : {0, 7, 14}) {
      EXPECT_NEAR(shadow.at(x, 3, z), lit / 5.0, 0.5 / 255 + 1e-6) << "x " << x << " z " << z;
    }
  }
  // The plate itself is lit: the light reaching a voxel is what passed the voxels above.
  EXPECT_EQ(shadow.at(2, 3, 15), 1.0);
  ShadowVolume sharp(dims, 0);
  sharp.update(texels_of(dims, [](int x, int, int z) { return x < 8 && z == 15 ? 255 : 0; }),
               opacity_of_full(1.0f));
  EXPECT_EQ(sharp.at(7, 3, 0), 0.0);
  EXPECT_EQ(sharp.at(8, 3, 0), 1.0);
}

// A plate moved sideways: its shadow moves with it, and recomputing only the columns of the
// bricks that changed gives exactly what recomputing the whole volume gives.
TEST(ShadowVolume, AMovedPlatesShadowMovesAndOnlyTheTouchedColumnsAreRecomputed) {
  const Eigen::Vector3i dims(48, 16, 16);
  auto plate_at = [&](int x0) {
    return texels_of(dims, [x0](int x, int, int z) {
      return x >= x0 && x < x0 + 8 && z >= 12 && z < 14 ? 255 : 0;
    });
  };
  const std::array<float, 256> opacity = opacity_of_full(0.9f);
  ShadowVolume shadow(dims, 1);
  shadow.update(plate_at(8), opacity);
  EXPECT_LT(shadow.at(12, 8, 2), 0.05);
  EXPECT_EQ(shadow.at(28, 8, 2), 1.0);
  // The plate moves from bricks x = 1 to x = 3: those bricks change.
  std::vector<std::uint32_t> changed;
  const Eigen::Vector3i bricks = brick_counts(dims);
  for (int bz = 0; bz < bricks.z(); ++bz) {
    for (int by = 0; by < bricks.y(); ++by) {
      for (int bx : {1, 3}) {
        changed.push_back(static_cast<std::uint32_t>((bz * bricks.y() + by) * bricks.x() + bx));
      }
    }
  }
  shadow.mark_bricks(changed);
  const std::vector<std::uint32_t> recomputed = shadow.update(plate_at(24), opacity);
  EXPECT_EQ(shadow.at(12, 8, 2), 1.0);   // the old shadow is gone
  EXPECT_LT(shadow.at(28, 8, 2), 0.05);  // the new one is under the plate
  ShadowVolume fresh(dims, 1);
  fresh.update(plate_at(24), opacity);
  EXPECT_EQ(shadow.transmittance(), fresh.transmittance());
  // Columns x = 0..4 in bricks (the changed ones and their neighbours, reached by the blur),
  // not column 5.
  for (std::uint32_t b : recomputed) {
    EXPECT_LE(static_cast<int>(b % static_cast<std::uint32_t>(bricks.x())), 4) << b;
  }
  EXPECT_EQ(recomputed.size(), static_cast<std::size_t>(5 * bricks.y() * bricks.z()));
  // Nothing marked: nothing recomputed.
  EXPECT_TRUE(shadow.update(plate_at(24), opacity).empty());
}

// One context for the suite: EGL displays are process-wide anyway.
GlContext& shared_context() {
  static GlContext gl;
  return gl;
}

// A plate floating 26 mm above a floor, 48^3 voxels of 1 mm.
engine::DensityField plate_over_floor() {
  engine::initialize_openvdb();
  auto grid = openvdb::FloatGrid::create(0.0f);
  auto access = grid->getAccessor();
  for (int z = 0; z < 48; ++z) {
    for (int y = 0; y < 48; ++y) {
      for (int x = 0; x < 48; ++x) {
        const bool floor = x >= 2 && x < 46 && y >= 2 && y < 46 && z >= 2 && z < 10;
        const bool plate = x >= 6 && x < 22 && y >= 12 && y < 36 && z >= 36 && z < 40;
        if (floor || plate) access.setValue(openvdb::Coord(x, y, z), 1.0f);
      }
    }
  }
  return engine::DensityField(grid, Eigen::Vector3d::Ones(), Eigen::Vector3d::Zero(),
                              Eigen::Vector3i::Constant(48));
}

// Seen from the +x side 35 degrees up: the plate hides no floor near its shadow.
struct PlateView {
  GlContext& context = shared_context();
  engine::DensityField field = plate_over_floor();
  VolumeRenderer renderer{field, TransferFunction::from_spec("clay")};
  OrbitCamera camera = OrbitCamera::framing(field.world_min_mm(), field.world_max_mm(), 0.0, 35.0);
  RenderSettings settings = [] {
    RenderSettings s;
    s.width = s.height = 128;
    s.draw_tool = false;
    return s;
  }();

  // Mean brightness of a 5x5-pixel patch around where a world point projects.
  double patch(const Image& image, const Eigen::Vector3d& at_mm) const {
    const Eigen::Matrix4d mvp = camera.projection(1.0, 1.0, 1e4) * camera.view();
    const Eigen::Vector4d clip = mvp * at_mm.homogeneous();
    const int px = static_cast<int>((clip.x() / clip.w() * 0.5 + 0.5) * settings.width);
    const int py = static_cast<int>((0.5 - clip.y() / clip.w() * 0.5) * settings.height);
    double sum = 0.0;
    for (int y = py - 2; y <= py + 2; ++y) {
      for (int x = px - 2; x <= px + 2; ++x) {
        const std::uint8_t* p = image.pixel(x, y);
        sum += (p[0] + p[1] + p[2]) / 3.0;
      }
    }
    return sum / 25.0;
  }
};

// Through EGL: with --shadows the floor under the plate darkens against the open floor;
// without, both are the same clay.
TEST(ShadowRender, ThePlateDarkensTheFloorBelowItOnlyWithShadowsOn) {
  PlateView view;
  const Eigen::Vector3d under_plate(14, 24, 9.5), open_floor(36, 24, 9.5);
  const Image plain = view.renderer.render(view.camera, ToolPose{}, view.settings);
  view.settings.shadows.enabled = true;
  const Image shadowed = view.renderer.render(view.camera, ToolPose{}, view.settings);
  const double plain_ratio = view.patch(plain, under_plate) / view.patch(plain, open_floor);
  const double shadow_ratio = view.patch(shadowed, under_plate) / view.patch(shadowed, open_floor);
  std::printf("floor under the plate / open floor: %.3f plain, %.3f with shadows\n", plain_ratio,
              shadow_ratio);
  EXPECT_NEAR(plain_ratio, 1.0, 0.05);
  EXPECT_LT(shadow_ratio, 0.75);
  // The plate's own top faces the light: darkened only by the clay its surface samples see
  // through (slices behind the surface, under it).
  const Eigen::Vector3d plate_top(14, 24, 39.5);
  EXPECT_GT(view.patch(shadowed, plate_top), 0.9 * view.patch(plain, plate_top));
  // Off again: today's image, bit for bit.
  view.settings.shadows.enabled = false;
  EXPECT_EQ(view.renderer.render(view.camera, ToolPose{}, view.settings).rgba, plain.rgba);
}

// The proxy mesh carries the plate 16 mm along +x (its upper vertices move, the floor's stay):
// the resampled bricks mark their columns and the next shadowed frame moves the shadow along.
TEST(ShadowRender, APlateTheProxyMeshMovesTakesItsShadowAlong) {
  PlateView view;
  view.settings.shadows.enabled = true;
  const Eigen::Vector3d old_place(14, 24, 9.5), new_place(30, 24, 9.5), open_floor(42, 24, 9.5);
  const Image before = view.renderer.render(view.camera, ToolPose{}, view.settings);
  ProxyResampler resampler(dense_copy(view.field));
  const engine::fem::TetMesh mesh =
      engine::fem::regular_lattice({7, 7, 7}, 47.0 / 6.0, Eigen::Vector3d::Zero());
  resampler.set_mesh(mesh);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(3 * mesh.vertex_count());
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    if (mesh.rest_mm(2, v) > 30.0) u[3 * v] = 16.0;  // the lattice's top two layers
  }
  resampler.update(u);
  view.renderer.replace_texels(resampler.texels(), resampler.changed_bricks());
  const Image after = view.renderer.render(view.camera, ToolPose{}, view.settings);
  const double old_before = view.patch(before, old_place) / view.patch(before, open_floor);
  const double new_before = view.patch(before, new_place) / view.patch(before, open_floor);
  const double old_after = view.patch(after, old_place) / view.patch(after, open_floor);
  const double new_after = view.patch(after, new_place) / view.patch(after, open_floor);
  std::printf("floor at the old / new place vs open floor: before %.3f / %.3f, after %.3f / %.3f\n",
              old_before, new_before, old_after, new_after);
  EXPECT_LT(old_before, 0.75);
  EXPECT_NEAR(new_before, 1.0, 0.05);
  EXPECT_NEAR(old_after, 1.0, 0.05);
  EXPECT_LT(new_after, 0.75);
}

}  // namespace
}  // namespace hapvox::render
