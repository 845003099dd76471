#include "render/volume_renderer.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstdlib>
#include <filesystem>
#include <memory>

#include "engine/relax.h"
#include "engine/volume_io.h"
#include "render/suite_gl_context.h"
#include "test_data.h"

namespace hapvox::render {
namespace {

using Eigen::Vector3d;

bool is_background(const Image& image, int x, int y, const RenderSettings& s) {
  const std::uint8_t* p = image.pixel(x, y);
  for (int c = 0; c < 3; ++c) {
    if (std::abs(int(p[c]) - int(std::lround(s.background[c] * 255.0f))) > 1) return false;
  }
  return true;
}

// Pixel box (x0, y0, x1, y1) of world points seen by `camera`.
Eigen::Vector4i project_box(const OrbitCamera& camera, const RenderSettings& s,
                            const std::vector<Vector3d>& points) {
  const Eigen::Matrix4d mvp =
      camera.projection(double(s.width) / s.height, 1.0, 1e5) * camera.view();
  Eigen::Vector4i box(s.width, s.height, 0, 0);
  for (const Vector3d& p : points) {
    const Eigen::Vector4d clip = mvp * p.homogeneous();
    const double x = (clip.x() / clip.w() * 0.5 + 0.5) * s.width;
    const double y = (0.5 - clip.y() / clip.w() * 0.5) * s.height;
    box[0] = std::min(box[0], int(std::floor(x)));
    box[1] = std::min(box[1], int(std::floor(y)));
    box[2] = std::max(box[2], int(std::ceil(x)));
    box[3] = std::max(box[3], int(std::ceil(y)));
  }
  return box;
}

std::vector<Vector3d> box_corners(const Vector3d& lo, const Vector3d& hi) {
  std::vector<Vector3d> corners;
  for (int k = 0; k < 8; ++k) {
    corners.emplace_back((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(),
                         (k & 4) ? hi.z() : lo.z());
  }
  return corners;
}

const engine::DensityField& engine_ct() {
  static const engine::DensityField field = engine::load_volume(
      testing::source_path("data/engine_256x256x128_uint8.nrrd"), engine::IntensityMapping{});
  return field;
}

// The bundled engine CT, bone preset, 256 x 256, from the default angles.
struct EngineView {
  VolumeRenderer renderer{(suite_gl_context(), engine_ct()),
                          TransferFunction::from_spec("ct-bone")};
  RenderSettings settings = [] {
    RenderSettings s;
    s.width = s.height = 256;
    return s;
  }();
  OrbitCamera camera =
      OrbitCamera::framing(engine_ct().world_min_mm(), engine_ct().world_max_mm(), 30.0, 25.0);
};

TEST(VolumeRenderer, DrawsTheEngineWhereItIsAndNothingElsewhere) {
  EngineView view;
  VolumeRenderer& renderer = view.renderer;
  const RenderSettings& settings = view.settings;
  const OrbitCamera& camera = view.camera;
  const Image image = renderer.render(camera, ToolPose{}, settings);
  const Eigen::Vector4i box = project_box(
      camera, settings, box_corners(renderer.visible_lo_mm(), renderer.visible_hi_mm()));
  std::size_t inside = 0, inside_drawn = 0, outside_drawn = 0;
  for (int y = 0; y < settings.height; ++y) {
    for (int x = 0; x < settings.width; ++x) {
      const bool drawn = !is_background(image, x, y, settings);
      if (x >= box[0] && x < box[2] && y >= box[1] && y < box[3]) {
        ++inside;
        inside_drawn += drawn;
      } else if (x < box[0] - 2 || x >= box[2] + 2 || y < box[1] - 2 || y >= box[3] + 2) {
        outside_drawn += drawn;
      }
    }
  }
  EXPECT_EQ(outside_drawn, 0u);
  EXPECT_GT(inside_drawn, inside / 5) << inside_drawn << " of " << inside;
  // The same frame twice is the same frame.
  EXPECT_EQ(renderer.render(camera, ToolPose{}, settings).rgba, image.rgba);
}

struct BlockScene {
  engine::DensityField field = engine::load_volume("block:dims=64", engine::IntensityMapping{});
  RenderSettings settings;
  OrbitCamera camera;
  ToolPose tool;
  BlockScene() {
    settings.width = settings.height = 256;
    settings.draw_tool = false;  // compare the material alone
    camera = OrbitCamera::framing(field.world_min_mm(), field.world_max_mm(), 20.0, 35.0);
    tool.radius_mm = 4.0;
    tool.center_mm = Vector3d(31.5, 31.5, 31.5 + 4.0 - 3.0);  // 3 mm into the top face
    tool.displacement_mm = Vector3d(0, 0, -3.0);
    tool.in_contact = true;
  }
};

// Renders `tool` pressing and the same tool resting (no displacement); the image must
// change where the tool presses and stay the same beyond the kernel's reach.
void expect_press_is_local(VolumeRenderer& renderer, const OrbitCamera& camera,
                           const RenderSettings& settings, const ToolPose& tool) {
  ToolPose resting = tool;
  resting.in_contact = false;
  const Image before = renderer.render(camera, resting, settings);
  const Image pressed = renderer.render(camera, tool, settings);
  const double reach = tool.radius_mm + 3.0 * tool.radius_mm + tool.displacement_mm.norm();
  const Eigen::Vector4i near = project_box(camera, settings,
                                           box_corners(tool.center_mm - Vector3d::Constant(reach),
                                                       tool.center_mm + Vector3d::Constant(reach)));
  // Where the tool presses: the image changes clearly.
  const Eigen::Vector4i at_tool =
      project_box(camera, settings,
                  box_corners(tool.center_mm - Vector3d::Constant(tool.radius_mm),
                              tool.center_mm + Vector3d::Constant(tool.radius_mm)));
  EXPECT_GT(mean_abs_difference(before, pressed, at_tool[0], at_tool[1], at_tool[2], at_tool[3]),
            2.0);
  // Far from it: the same image (to rounding in the re-tessellated slices).
  double far_sum = 0.0;
  std::size_t far_count = 0, far_changed = 0;
  for (int y = 0; y < settings.height; ++y) {
    for (int x = 0; x < settings.width; ++x) {
      if (x >= near[0] - 2 && x < near[2] + 2 && y >= near[1] - 2 && y < near[3] + 2) continue;
      const double d = mean_abs_difference(before, pressed, x, y, x + 1, y + 1);
      far_sum += d;
      far_changed += d > 1.0;
      ++far_count;
    }
  }
  ASSERT_GT(far_count, 10000u);
  EXPECT_LT(far_sum / far_count, 0.01);
  EXPECT_LT(far_changed, far_count / 1000);
  // And no vertex was moved in contact-free frames.
  EXPECT_EQ(renderer.render(camera, resting, settings).rgba, before.rgba);
}

TEST(VolumeRenderer, AnElasticPressDisplacesTheImageNearTheToolAndNowhereFar) {
  suite_gl_context();
  BlockScene scene;
  VolumeRenderer renderer(scene.field, TransferFunction::from_spec("clay"));
  expect_press_is_local(renderer, scene.camera, scene.settings, scene.tool);
}

TEST(VolumeRenderer, AnElasticPressOnTheEngineShowsWhereTheToolPressesOnly) {
  // The bundled trace's press: the 8 mm tool 3 mm into the flat top of the engine block
  // (face at z = 107.5 mm), seen from close by.
  EngineView view;
  view.settings.draw_tool = false;
  ToolPose tool;
  tool.radius_mm = 4.0;
  tool.center_mm = Vector3d(128.0, 64.0, 107.5 + 4.0 - 3.0);
  tool.displacement_mm = Vector3d(0, 0, -3.0);
  tool.in_contact = true;
  OrbitCamera close = view.camera;
  close.target_mm = tool.center_mm;
  close.distance_mm = 120.0;
  expect_press_is_local(view.renderer, close, view.settings, tool);
}

TEST(VolumeRenderer, PlasticChangesAppearOnceRelaxedAndMatchAFreshUpload) {
  suite_gl_context();
  BlockScene scene;
  VolumeRenderer renderer(scene.field, TransferFunction::from_spec("clay"));
  const Image before = renderer.render(scene.camera, ToolPose{}, scene.settings);
  // Sculpt: push the tool 6 mm into the top face, relax until settled.
  engine::MassGrid mass(scene.field);
  engine::SurfaceChange change;
  change.from_mm = Vector3d(31.5, 31.5, 36.0);
  change.position_mm = Vector3d(31.5, 31.5, 30.0);
  change.direction = Vector3d(0, 0, -1);
  change.radius_mm = 4.0;
  ASSERT_GT(mass.apply_deletion(change), 50u);
  for (int i = 0; i < 1000 && !mass.settled(); ++i) mass.relax(5000);
  ASSERT_TRUE(mass.settled());
  std::vector<openvdb::Coord> changed;
  mass.take_changes(changed);
  ASSERT_FALSE(changed.empty());
  // Not yet handed to the renderer: the frame is unchanged.
  EXPECT_EQ(renderer.render(scene.camera, ToolPose{}, scene.settings).rgba, before.rgba);
  for (const openvdb::Coord& ijk : changed) renderer.set_voxel(ijk, mass.density(ijk));
  const std::uint64_t bricks_before = renderer.bricks_uploaded();
  const Image after = renderer.render(scene.camera, ToolPose{}, scene.settings);
  // Only the bricks the change touched went up, not the whole 8x8x8 bricks of the volume.
  const std::uint64_t uploaded = renderer.bricks_uploaded() - bricks_before;
  EXPECT_GT(uploaded, 0u);
  EXPECT_LT(uploaded, 8u * 8u * 8u / 4u);
  const Eigen::Vector4i dent =
      project_box(scene.camera, scene.settings,
                  box_corners(Vector3d(27.5, 27.5, 28.0), Vector3d(35.5, 35.5, 32.0)));
  EXPECT_GT(mean_abs_difference(before, after, dent[0], dent[1], dent[2], dent[3]), 2.0);
  // Incremental updates give the frame a fresh upload of the sculpted volume gives.
  const engine::DensityField sculpted = mass.to_density_field();
  VolumeRenderer fresh(sculpted, TransferFunction::from_spec("clay"));
  EXPECT_GT(psnr_db(fresh.render(scene.camera, ToolPose{}, scene.settings), after), 50.0);
}

// Issue 29 point 5: front to back with early termination draws what back to front draws,
// up to the 8-bit framebuffer's rounding: an opaque block pressed by the drawn tool, the
// engine's bone, and translucent soft tissue (where a mask that took pixels for opaque too
// early would drop what lies behind them).
// Both orders round each blend to 8 bits, in a different sequence: measured 3, 2 and 9 of
// 255 at worst (the 9 behind ~100 translucent slices), PSNR 53-63 dB. A mask that took
// alpha 0.9 for opaque gives 18, 23 and 25 (PSNR 44-52 dB); a tool left uncoloured, 188.
constexpr int kMaxRoundingLsb = 12;

TEST(VolumeRenderer, FrontToBackWithEarlyEndDrawsWhatBackToFrontDraws) {
  BlockScene block;
  block.settings.draw_tool = true;
  VolumeRenderer clay((suite_gl_context(), block.field), TransferFunction::from_spec("clay"));
  EngineView engine;
  ToolPose engine_tool;
  engine_tool.radius_mm = 6.0;
  engine_tool.center_mm = Vector3d(128.0, 64.0, 110.0);
  const engine::DensityField spheres =
      engine::load_volume("four-spheres:dims=96", engine::IntensityMapping{});
  VolumeRenderer soft(spheres, TransferFunction::from_spec("ct-soft"));
  const OrbitCamera soft_camera =
      OrbitCamera::framing(spheres.world_min_mm(), spheres.world_max_mm(), 30.0, 25.0);
  RenderSettings soft_settings = engine.settings;
  struct Case {
    const char* name;
    VolumeRenderer& renderer;
    const OrbitCamera& camera;
    const ToolPose& tool;
    RenderSettings settings;
  };
  for (Case c : {Case{"clay block", clay, block.camera, block.tool, block.settings},
                 Case{"engine", engine.renderer, engine.camera, engine_tool, engine.settings},
                 Case{"soft spheres", soft, soft_camera, ToolPose{}, soft_settings}}) {
    SCOPED_TRACE(c.name);
    RenderSettings back_settings = c.settings;
    back_settings.early_termination = false;
    const Image front = c.renderer.render(c.camera, c.tool, c.settings);
    const Image back = c.renderer.render(c.camera, c.tool, back_settings);
    int worst = 0;
    for (std::size_t i = 0; i < front.rgba.size(); ++i) {
      worst = std::max(worst, std::abs(int(front.rgba[i]) - int(back.rgba[i])));
    }
    EXPECT_LE(worst, kMaxRoundingLsb);
    EXPECT_LT(mean_abs_difference(front, back, 0, 0, front.width, front.height), 0.5);
    EXPECT_GT(psnr_db(front, back), 52.0);
    std::printf("%s: largest difference %d of 255, PSNR %.1f dB\n", c.name, worst,
                psnr_db(front, back));
  }
}

TEST(VolumeRenderer, MatchesTheGoldenImage) {
  EngineView view;
  VolumeRenderer& renderer = view.renderer;
  const RenderSettings& settings = view.settings;
  const OrbitCamera& camera = view.camera;
  ToolPose tool;
  tool.radius_mm = 6.0;
  tool.center_mm = Vector3d(128.0, 64.0, 110.0);
  const Image image = renderer.render(camera, tool, settings);
  const std::string golden = testing::source_path("tests/render/golden/engine_256.png");
  if (std::getenv("HAPVOX_UPDATE_GOLDEN") != nullptr) write_png(image, golden);
  // Drivers and their versions differ in rounding; the picture must not.
  EXPECT_GT(psnr_db(read_png(golden), image), 35.0);
}

TEST(VolumeRenderer, ManySlicesConvergeToTheReference) {
  // Quality property: our default slicing is within 35 dB of a 1000-slice reference.
  EngineView view;
  VolumeRenderer& renderer = view.renderer;
  const RenderSettings& settings = view.settings;
  const OrbitCamera& camera = view.camera;
  RenderSettings reference = settings;
  reference.mesh.slices = 1000;
  const Image ours = renderer.render(camera, ToolPose{}, settings);
  const Image ref = renderer.render(camera, ToolPose{}, reference);
  RenderSettings coarse = settings;
  coarse.mesh.slices = 32;
  const double ours_db = psnr_db(ours, ref);
  EXPECT_GT(ours_db, 35.0);
  EXPECT_LT(psnr_db(renderer.render(camera, ToolPose{}, coarse), ref), ours_db);
}

}  // namespace
}  // namespace hapvox::render
