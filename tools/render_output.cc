#include "tools/render_output.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <thread>

#include <tbb/task_arena.h>

#include "engine/check.h"
#include "engine/errors.h"

namespace hapvox::cli {

namespace fs = std::filesystem;

void parse_size(const std::string& text, const std::string& flag, int& width, int& height) {
  const auto x = text.find('x');
  char* end = nullptr;
  const long w = std::strtol(text.c_str(), &end, 10);
  long h = w;
  if (x != std::string::npos && end == text.c_str() + x) {
    h = std::strtol(text.c_str() + x + 1, &end, 10);
  }
  if (text.empty() || *end != '\0' || w < 16 || h < 16 || w > 8192 || h > 8192) {
    throw InputError(flag, "expected N or WxH with 16 <= N <= 8192, got '" + text + "'");
  }
  width = static_cast<int>(w);
  height = static_cast<int>(h);
}

std::string transfer_spec_for(const std::string& transfer, const std::string& volume_spec) {
  if (transfer != "auto") return transfer;
  return fs::exists(volume_spec) ? "ct-bone" : "clay";
}

void RenderFlags::add_to(CLI::App& app, const std::string& prefix) {
  const std::string p = "--" + prefix;
  app.add_option(p + "transfer", transfer,
                 "Transfer function: clay, ct-bone, ct-soft or a file (auto: ct-bone for "
                 "files, clay for generators)")
      ->capture_default_str();
  app.add_option(p + "size", size, "Image size N or WxH, pixels")->capture_default_str();
  app.add_option(p + "slices", slices, "View-aligned slices across the volume")
      ->capture_default_str();
  app.add_option(p + "tessellation", tessellation,
                 "adaptive (fine only near the tool) or uniform (patches x patches)")
      ->capture_default_str();
  app.add_option(p + "patches", patches, "Patches per slice side (uniform)")->capture_default_str();
  app.add_option(p + "kernel", kernel, "FFD falloff: wendland (compact) or paper (Eq. 10)")
      ->capture_default_str();
  app.add_option(p + "support-mm", support_mm, "Wendland support R (0: 3 tool radii)")
      ->capture_default_str();
  app.add_option(p + "azimuth-deg", azimuth_deg, "Camera azimuth")->capture_default_str();
  app.add_option(p + "elevation-deg", elevation_deg, "Camera elevation")->capture_default_str();
  app.add_option(p + "gradient", gradient,
                 "--model fem: how shading turns with the proxy mesh: rotation (per-vertex "
                 "R = N'N^T, Nakao) or inverse-transpose (each tet's F^-T)")
      ->capture_default_str();
  app.add_flag(p + "shadows", shadows,
               "Volume shadows from a light above the volume (its +z side), soft-edged; they "
               "move with the material");
}

RenderSetup resolve_render_flags(const RenderFlags& f, const std::string& volume_spec,
                                 const engine::DensityField& field, const std::string& prefix) {
  const std::string p = "--" + prefix;
  RenderSetup setup;
  render::RenderSettings& s = setup.settings;
  parse_size(f.size, p + "size", s.width, s.height);
  if (f.slices < 1 || f.slices > 4096) throw InputError(p + "slices", "must lie in [1, 4096]");
  if (f.patches < 1 || f.patches > 512) throw InputError(p + "patches", "must lie in [1, 512]");
  s.mesh.slices = f.slices;
  s.mesh.patches = f.patches;
  if (f.tessellation == "adaptive") {
    s.mesh.tessellation = render::Tessellation::kAdaptive;
  } else if (f.tessellation == "uniform") {
    s.mesh.tessellation = render::Tessellation::kUniform;
  } else {
    throw InputError(p + "tessellation",
                     "expected adaptive or uniform, got '" + f.tessellation + "'");
  }
  if (f.kernel == "wendland") {
    s.mesh.kernel = render::FfdKernel::kWendland;
  } else if (f.kernel == "paper") {
    s.mesh.kernel = render::FfdKernel::kPaper;
  } else {
    throw InputError(p + "kernel", "expected wendland or paper, got '" + f.kernel + "'");
  }
  if (!(f.support_mm >= 0.0) || !std::isfinite(f.support_mm)) {
    throw InputError(p + "support-mm", "must be zero (3 tool radii) or positive");
  }
  if (!std::isfinite(f.azimuth_deg) || !std::isfinite(f.elevation_deg)) {
    throw InputError(p + "azimuth-deg", "camera angles must be finite");
  }
  s.mesh.support_mm = f.support_mm;
  s.mesh.voxel_mm = field.voxel_size_mm().minCoeff();
  setup.transfer_spec = transfer_spec_for(f.transfer, volume_spec);
  render::TransferFunction::from_spec(setup.transfer_spec);  // validated now, loaded later
  setup.azimuth_deg = f.azimuth_deg;
  setup.elevation_deg = f.elevation_deg;
  setup.resample.gradient = render::parse_gradient_transform(f.gradient, p + "gradient");
  s.shadows.enabled = f.shadows;
  return setup;
}

FrameRecorder::FrameRecorder(const engine::DensityField& field, const RenderSetup& setup,
                             std::string dir, double tool_radius_mm, bool on_render_thread)
    : field_(field),
      setup_(setup),
      dir_(std::move(dir)),
      tool_radius_mm_(tool_radius_mm),
      settings_(setup.settings),
      on_render_thread_(on_render_thread) {
  if (fs::exists(dir_) && !fs::is_directory(dir_)) {
    throw InputError(dir_, "exists and is not a directory");
  }
  camera_ = render::OrbitCamera::framing(field.grid_min_mm(), field.grid_max_mm(),
                                         setup.azimuth_deg, setup.elevation_deg);
  if (on_render_thread) {
    render::GlContext probe;  // a missing EGL fails here, before any output
  } else {
    make_renderer();
  }
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec) throw InputError(dir_, "cannot be created: " + ec.message());
}

void FrameRecorder::make_renderer() {
  context_ = std::make_unique<render::GlContext>();
  renderer_ = std::make_unique<render::VolumeRenderer>(
      field_, render::TransferFunction::from_spec(setup_.transfer_spec));
  if (resampler_ && resamples_ > 0) {  // a renderer made after a deformation: all of it
    const Eigen::Vector3i bricks = render::brick_counts(resampler_->dims());
    std::vector<std::uint32_t> all(static_cast<std::size_t>(bricks.prod()));
    for (std::size_t b = 0; b < all.size(); ++b) all[b] = static_cast<std::uint32_t>(b);
    renderer_->replace_texels(resampler_->texels(), all);
  }
}

void FrameRecorder::use_proxy_mesh() {
  resampler_ =
      std::make_unique<render::ProxyResampler>(render::dense_copy(field_), setup_.resample);
}

void FrameRecorder::deform(const engine::fem::TetMesh& mesh, int mesh_index,
                           const Eigen::Ref<const Eigen::VectorXd>& displacement_mm) {
  HAPVOX_CHECK(resampler_ != nullptr);
  if (mesh_index != mesh_index_) {
    resampler_->set_mesh(mesh);
    mesh_index_ = mesh_index;
  }
  // On a realtime render thread the resample stays on that thread: TBB's workers would
  // compete with the force and FEM threads for the CPUs (under TSan they slowed the realtime
  // test from 12 s to 73 s). Lockstep frames resample on every core.
  render::ResampleStats stats;
  if (on_render_thread_) {
    tbb::task_arena one_thread(1);
    one_thread.execute([&] { stats = resampler_->update(displacement_mm); });
  } else {
    stats = resampler_->update(displacement_mm);
  }
  ++resamples_;
  resample_ms_total_ += stats.ms;
  if (renderer_) renderer_->replace_texels(resampler_->texels(), resampler_->changed_bricks());
}

FrameRecorder::~FrameRecorder() {
  if (!context_) return;
  try {
    context_->make_current();
  } catch (const render::RenderError&) {
    return;  // cannot free GL objects without a context; the process ends soon anyway
  }
  renderer_.reset();
}

render::Image FrameRecorder::render_now(const haptics::RenderToolState& tool,
                                        const render::OrbitCamera& camera,
                                        render::FrameStats* stats) {
  render::ToolPose pose;
  if (tool.tick >= 0) {
    // The renderer draws the grid frame; the tool moves in world.
    pose.center_mm = field_.world_to_grid(tool.center_mm);
    pose.radius_mm = tool_radius_mm_;
    if (!resampler_) {  // the FFD's press; the proxy mesh's deformation is in the texture
      pose.displacement_mm = field_.direction().transpose() * tool.displacement_mm;
      pose.in_contact = tool.in_contact;
    }
  }
  return renderer_->render(camera, pose, settings_, stats);
}

void FrameRecorder::draw(const haptics::RenderToolState& tool, const render::OrbitCamera* camera) {
  render::FrameStats stats;
  const render::Image image = render_now(tool, camera != nullptr ? *camera : camera_, &stats);
  char name[32];
  std::snprintf(name, sizeof name, "frame_%04d.png", frames_++);
  render::write_png(image, (fs::path(dir_) / name).string());
  frame_ms_total_ += stats.mesh_ms + stats.upload_ms + stats.draw_ms + stats.read_ms;
}

haptics::RenderLoop FrameRecorder::realtime_loop(double fps) {
  return [this, fps](haptics::RenderFeed& feed, haptics::RenderTiming& timing) {
    using Clock = std::chrono::steady_clock;
    make_renderer();
    const auto period = std::chrono::nanoseconds(std::llround(1e9 / fps));
    auto next = Clock::now();
    haptics::VoxelPatch patch;
    std::int64_t deformed_tick = -1;
    while (true) {
      const bool finishing = feed.done.load(std::memory_order_acquire);
      while (feed.voxels.pop(patch)) {
        renderer_->set_voxel(patch.ijk, patch.density);
        ++timing.voxels_applied;
      }
      const haptics::RenderToolState tool = feed.tool.read();
      const auto begin = Clock::now();
      if (resampler_) {
        const haptics::MeshDisplacement& latest = feed.mesh.read();
        if (latest.tick >= 0 && latest.tick != deformed_tick) {
          deform(*latest.mesh, latest.mesh_index,
                 Eigen::Map<const Eigen::VectorXd>(
                     latest.displacement_mm.data(),
                     static_cast<Eigen::Index>(latest.displacement_mm.size())));
          deformed_tick = latest.tick;
        }
      }
      draw(tool);
      timing.record_frame(feed.start, begin, tool.tick);
      if (finishing) break;
      // Absolute deadlines: a frame that ran long is made up for by starting the next one
      // at once, but by one period at most (a long stall is not followed by a burst).
      next = std::max(next + period, Clock::now() - period);
      while (Clock::now() < next && !feed.done.load(std::memory_order_acquire)) {
        std::this_thread::sleep_for(
            std::min<Clock::duration>(next - Clock::now(), std::chrono::milliseconds(5)));
      }
    }
    renderer_.reset();
    context_.reset();
  };
}

}  // namespace hapvox::cli
