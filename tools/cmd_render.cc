// hapvox render VOLUME [--trace T] -o DIR: frames of the volume drawn headless (EGL),
// stills or a turntable, or a lockstep replay of a trace with the tool pressing (and, with
// --plastic, sculpting) the volume, a frame every N ticks.

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>

#include "engine/errors.h"
#include "engine/relax.h"
#include "render/gl_context.h"
#include "render/volume_renderer.h"
#include "tools/cli.h"

namespace hapvox::cli {
namespace {

namespace fs = std::filesystem;

struct RenderFlags {
  std::string volume;
  std::string output;
  std::string trace_path;
  MappingFlags mapping;
  TraceFlags trace;
  TransformFlags transform;
  ForceFlags force;
  std::string transfer = "auto";
  std::string size = "512";
  int slices = 256;
  std::string tessellation = "adaptive";
  int patches = 20;
  std::string kernel = "wendland";
  double support_mm = 0.0;
  double azimuth_deg = 30.0;
  double elevation_deg = 25.0;
  int turntable = 0;
  std::size_t every_ticks = 100;
  bool plastic = false;
  bool video = false;
  bool quiet = false;
};

void parse_size(const std::string& text, int& width, int& height) {
  const auto x = text.find('x');
  char* end = nullptr;
  const long w = std::strtol(text.c_str(), &end, 10);
  long h = w;
  if (x != std::string::npos) h = std::strtol(text.c_str() + x + 1, &end, 10);
  if (end == nullptr || *end != '\0' || w < 16 || h < 16 || w > 8192 || h > 8192) {
    throw InputError("--size", "expected N or WxH with 16 <= N <= 8192, got '" + text + "'");
  }
  width = static_cast<int>(w);
  height = static_cast<int>(h);
}

render::SliceMeshOptions mesh_options(const RenderFlags& f, const engine::DensityField& field) {
  render::SliceMeshOptions options;
  if (f.slices < 1 || f.slices > 4096) throw InputError("--slices", "must lie in [1, 4096]");
  if (f.patches < 1 || f.patches > 512) throw InputError("--patches", "must lie in [1, 512]");
  options.slices = f.slices;
  options.patches = f.patches;
  if (f.tessellation == "adaptive") {
    options.tessellation = render::Tessellation::kAdaptive;
  } else if (f.tessellation == "uniform") {
    options.tessellation = render::Tessellation::kUniform;
  } else {
    throw InputError("--tessellation", "expected adaptive or uniform, got '" + f.tessellation + "'");
  }
  if (f.kernel == "wendland") {
    options.kernel = render::FfdKernel::kWendland;
  } else if (f.kernel == "paper") {
    options.kernel = render::FfdKernel::kPaper;
  } else {
    throw InputError("--kernel", "expected wendland or paper, got '" + f.kernel + "'");
  }
  if (!(f.support_mm >= 0.0) || !std::isfinite(f.support_mm)) {
    throw InputError("--support-mm", "must be zero (3 tool radii) or positive");
  }
  options.support_mm = f.support_mm;
  options.voxel_mm = field.voxel_size_mm().minCoeff();
  return options;
}

void write_frame(const render::Image& image, const std::string& dir, int index) {
  char name[32];
  std::snprintf(name, sizeof name, "frame_%04d.png", index);
  render::write_png(image, (fs::path(dir) / name).string());
}

void encode_video(const std::string& dir, bool quiet) {
  if (std::system("command -v ffmpeg >/dev/null 2>&1") != 0) {
    std::printf("no video: ffmpeg is not installed (the frames are PNGs in %s)\n", dir.c_str());
    return;
  }
  const std::string command = "ffmpeg -y -loglevel error -framerate 25 -i '" + dir +
                              "/frame_%04d.png' -pix_fmt yuv420p '" + dir + "/frames.mp4'";
  if (std::system(command.c_str()) != 0) {
    throw InputError(dir + "/frames.mp4", "ffmpeg could not encode the frames");
  }
  if (!quiet) std::printf("wrote %s/frames.mp4\n", dir.c_str());
}

void run_render(const RenderFlags& f) {
  int width = 0, height = 0;
  parse_size(f.size, width, height);
  if (f.turntable < 0 || f.turntable > 3600) {
    throw InputError("--turntable", "must lie in [0, 3600] frames");
  }
  if (f.every_ticks < 1) throw InputError("--every-ticks", "must be at least 1");
  if (f.output.empty()) throw InputError("--output", "an output directory is required");
  if (fs::exists(f.output) && !fs::is_directory(f.output)) {
    throw InputError(f.output, "exists and is not a directory");
  }
  if (f.turntable > 0 && !f.trace_path.empty()) {
    throw InputError("--turntable", "cannot be combined with --trace");
  }
  if (f.plastic && f.trace_path.empty()) throw InputError("--plastic", "needs --trace");
  const engine::IntensityMapping mapping = f.mapping.resolve();
  const std::string transfer_spec =
      f.transfer != "auto" ? f.transfer
      : fs::exists(f.volume) ? "ct-bone"
                             : "clay";
  const render::TransferFunction transfer = render::TransferFunction::from_spec(transfer_spec);
  engine::DensityField field = engine::load_volume(f.volume, mapping);
  render::RenderSettings settings;
  settings.width = width;
  settings.height = height;
  settings.mesh = mesh_options(f, field);
  std::unique_ptr<haptics::TraceDevice> device;
  haptics::Trace trace;
  if (!f.trace_path.empty()) {
    const haptics::TraceColumns columns = f.trace.columns();
    trace = haptics::read_trace(f.trace_path, columns);
    haptics::ResampleOptions resample_options;
    resample_options.rate_hz = f.trace.rate_hz;
    resample_options.max_gap_s = f.trace.max_gap_s;
    device = std::make_unique<haptics::TraceDevice>(haptics::resample(trace, resample_options),
                                                    f.transform.resolve(trace, field));
  }
  engine::ToolForceOptions force_options = f.force.options;
  force_options.plastic.enabled = f.plastic;
  const engine::ToolForceModel model(field, force_options);

  // Everything the user gave is valid: only now create the output and the GL context.
  fs::create_directories(f.output);
  render::GlContext context;
  render::VolumeRenderer renderer(field, transfer);
  if (!f.quiet) {
    std::printf("renderer: %s, OpenGL %s\n", context.renderer().c_str(), context.version().c_str());
  }
  const render::OrbitCamera base = render::OrbitCamera::framing(
      field.world_min_mm(), field.world_max_mm(), f.azimuth_deg, f.elevation_deg);
  int frames = 0;
  double draw_ms = 0.0;
  auto draw = [&](const render::OrbitCamera& camera, const render::ToolPose& tool) {
    render::FrameStats stats;
    const render::Image image = renderer.render(camera, tool, settings, &stats);
    write_frame(image, f.output, frames++);
    draw_ms += stats.mesh_ms + stats.upload_ms + stats.draw_ms + stats.read_ms;
  };

  if (!device) {
    const int count = std::max(1, f.turntable);
    for (int i = 0; i < count; ++i) {
      render::OrbitCamera camera = base;
      camera.azimuth_deg = f.azimuth_deg + 360.0 * i / count;
      draw(camera, render::ToolPose{});
    }
  } else {
    // Lockstep: force stage, then (sculpting) deletions, a relaxation budget and the
    // changed voxels into the field the force reads and into the renderer.
    engine::ToolForceState state = model.make_state();
    haptics::DeviceLimits limits;
    std::unique_ptr<engine::MassGrid> mass;
    haptics::SurfaceChangeChannel channel;
    if (f.plastic) mass = std::make_unique<engine::MassGrid>(field);
    std::vector<openvdb::Coord> changed;
    auto accessor = field.mutable_grid().getAccessor();
    for (std::size_t tick = 0; tick < device->tick_count(); ++tick) {
      haptics::TickRecord row;
      haptics::run_force_stage(model, *device, tick, limits, state, mass ? &channel : nullptr,
                               row);
      if (mass) {
        engine::SurfaceChange change;
        while (channel.pop(change)) mass->apply_deletion(change);
        mass->relax(2000);
        mass->take_changes(changed);
        for (const openvdb::Coord& ijk : changed) {
          const float rho = mass->density(ijk);
          if (rho > 0.0f) {
            accessor.setValueOn(ijk, rho);
          } else {
            accessor.setValueOff(ijk, 0.0f);
          }
          renderer.set_voxel(ijk, rho);
        }
        if (!changed.empty()) state.invalidate_cache();
      }
      if (tick % f.every_ticks == 0 || tick + 1 == device->tick_count()) {
        render::ToolPose tool;
        tool.center_mm = row.tool_position_mm;
        tool.displacement_mm = state.displacement_mm;
        tool.in_contact = state.in_contact;
        tool.radius_mm = 0.5 * model.options().tool.diameter_mm;
        draw(base, tool);
      }
    }
  }
  if (!f.quiet) {
    std::printf("wrote %d frame%s of %dx%d to %s (%.1f ms a frame, %.1f fps)\n", frames,
                frames == 1 ? "" : "s", width, height, f.output.c_str(), draw_ms / frames,
                1000.0 * frames / draw_ms);
  }
  if (f.video) encode_video(f.output, f.quiet);
}

}  // namespace

void add_render_command(CLI::App& app) {
  auto flags = std::make_shared<RenderFlags>();
  CLI::App* cmd = app.add_subcommand(
      "render", "Draw a volume headless (EGL): stills, a turntable, or a trace being replayed");
  cmd->add_option("volume", flags->volume, "Volume file (.nrrd, .nhdr, .vdb) or generator")
      ->required();
  cmd->add_option("--output,-o", flags->output, "Directory for frame_NNNN.png (created)")
      ->required();
  cmd->add_option("--trace", flags->trace_path, "Replay this trace (lockstep) and draw the tool");
  cmd->add_option("--transfer", flags->transfer,
                  "Transfer function: clay, ct-bone, ct-soft or a file (auto: ct-bone for "
                  "files, clay for generators)")
      ->capture_default_str();
  cmd->add_option("--size", flags->size, "Image size N or WxH, pixels")->capture_default_str();
  cmd->add_option("--slices", flags->slices, "View-aligned slices")->capture_default_str();
  cmd->add_option("--tessellation", flags->tessellation,
                  "adaptive (fine only near the tool) or uniform (patches x patches)")
      ->capture_default_str();
  cmd->add_option("--patches", flags->patches, "Patches per slice side (uniform)")
      ->capture_default_str();
  cmd->add_option("--kernel", flags->kernel, "FFD falloff: wendland (compact) or paper (Eq. 10)")
      ->capture_default_str();
  cmd->add_option("--support-mm", flags->support_mm, "Wendland support R (0: 3 tool radii)")
      ->capture_default_str();
  cmd->add_option("--azimuth-deg", flags->azimuth_deg, "Camera azimuth")->capture_default_str();
  cmd->add_option("--elevation-deg", flags->elevation_deg, "Camera elevation")
      ->capture_default_str();
  cmd->add_option("--turntable", flags->turntable, "Frames of a full turn around the volume");
  cmd->add_option("--every-ticks", flags->every_ticks, "With --trace: a frame every N ticks")
      ->capture_default_str();
  cmd->add_flag("--plastic", flags->plastic, "With --trace: sculpt (plasticity and relaxation)");
  cmd->add_flag("--video", flags->video, "Also encode frames.mp4 (needs ffmpeg)");
  cmd->add_flag("--quiet,-q", flags->quiet, "No summary");
  flags->mapping.add_to(*cmd);
  flags->trace.add_to(*cmd);
  flags->transform.add_to(*cmd);
  flags->force.add_to(*cmd);
  cmd->callback([flags] { run_render(*flags); });
}

}  // namespace hapvox::cli
