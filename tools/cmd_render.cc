// hapvox render VOLUME [--trace T] -o DIR: frames of the volume drawn headless (EGL),
// stills or a turntable, or a lockstep replay of a trace with the tool pressing (and, with
// --plastic, sculpting) the volume, a frame every N ticks. --model fem: tools/render_fem.cc.

#include <cstdio>
#include <cstdlib>
#include <memory>

#include "engine/errors.h"
#include "engine/relax.h"
#include "haptics/trace_resample.h"
#include "haptics/voxel_model.h"
#include "tools/cli.h"
#include "tools/render_command.h"

namespace hapvox::cli {
namespace {

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

}  // namespace

std::unique_ptr<haptics::TraceDevice> render_trace_device(const RenderCommandFlags& f,
                                                          const engine::DensityField& field) {
  if (f.trace_path.empty()) return nullptr;
  const haptics::Trace trace = haptics::read_trace(f.trace_path, f.trace.columns());
  haptics::ResampleOptions resample_options;
  resample_options.rate_hz = f.trace.rate_hz;
  resample_options.max_gap_s = f.trace.max_gap_s;
  auto device = std::make_unique<haptics::TraceDevice>(
      haptics::resample(trace, resample_options, f.trace_path), f.transform.resolve(trace, field));
  if (device->tick_count() == 0) throw InputError(f.trace_path, "the trace has no samples");
  return device;
}

void draw_stills(FrameRecorder& recorder, int turntable) {
  const int count = std::max(1, turntable);
  for (int i = 0; i < count; ++i) {
    render::OrbitCamera camera = recorder.camera();
    camera.azimuth_deg += 360.0 * i / count;
    recorder.draw(haptics::RenderToolState{}, &camera);
  }
}

namespace {

void run_render(const RenderCommandFlags& f) {
  if (f.model != "voxel" && f.model != "fem") {
    throw InputError("--model", "expected voxel or fem, got '" + f.model + "'");
  }
  if (f.model == "voxel") {
    if (!f.fem_mesh.materials.empty()) throw InputError("--materials", "needs --model fem");
    if (!f.fem_run.incision.empty()) throw InputError("--incision", "needs --model fem");
  }
  if (f.turntable < 0 || f.turntable > 3600) {
    throw InputError("--turntable", "must lie in [0, 3600] frames");
  }
  if (f.every_ticks < 1) throw InputError("--every-ticks", "must be at least 1");
  if (f.turntable > 0 && !f.trace_path.empty()) {
    throw InputError("--turntable", "cannot be combined with --trace");
  }
  if (f.plastic && f.trace_path.empty()) throw InputError("--plastic", "needs --trace");
  if (f.model == "fem") {
    run_fem_render(f);
    if (f.video) encode_video(f.output, f.quiet);
    return;
  }
  std::vector<InputPath> inputs = volume_inputs(f.volume);
  if (!f.trace_path.empty()) inputs.push_back({f.trace_path, "trace"});
  for (const InputPath& input : transfer_inputs(f.render.transfer)) inputs.push_back(input);
  const std::string written = std::string(kFrameFileNames) + (f.video ? "|frames\\.mp4" : "");
  check_outputs_spare_inputs({{f.output, "--output", written}}, inputs);
  const engine::IntensityMapping mapping = f.mapping.resolve();
  engine::DensityField field = engine::load_volume(f.volume, mapping);
  const RenderSetup setup = resolve_render_flags(f.render, f.volume, field);
  const std::unique_ptr<haptics::TraceDevice> device = render_trace_device(f, field);
  engine::ToolForceOptions force_options = f.force.resolve();
  force_options.plastic.enabled = f.plastic;
  const engine::ToolForceModel model(field, force_options);

  // Everything the user gave is valid: only now the output and the GL context.
  FrameRecorder recorder(field, setup, f.output, 0.5 * model.options().tool.diameter_mm);
  if (!f.quiet) {
    std::printf("renderer: %s, OpenGL %s\n", recorder.context().renderer().c_str(),
                recorder.context().version().c_str());
  }
  if (!device) {
    draw_stills(recorder, f.turntable);
  } else {
    // The lockstep replay, the same stages as `hapvox replay`, drawing every N ticks.
    std::unique_ptr<engine::MassGrid> mass;
    haptics::SurfaceChangeChannel channel;
    haptics::SculptContext sculpt;
    if (f.plastic) {
      mass = std::make_unique<engine::MassGrid>(field);
      sculpt.mass = mass.get();
      sculpt.mirror = &field;
      sculpt.channel = &channel;
      sculpt.mass_every_ticks = 0;  // no session to record the total in
    }
    haptics::LockstepRender render;
    render.every_ticks = f.every_ticks;
    render.frame = [&](std::size_t, const haptics::RenderToolState& tool) { recorder.draw(tool); };
    render.voxel_changed = [&](const openvdb::Coord& ijk, float rho) {
      recorder.set_voxel(ijk, rho);
    };
    haptics::replay_lockstep(model, *device, haptics::DeviceLimits{}, nullptr, {},
                             f.plastic ? &sculpt : nullptr, nullptr, &render);
  }
  if (!f.quiet) {
    const render::RenderSettings& s = setup.settings;
    std::printf("wrote %d frame%s of %dx%d to %s (%.1f ms a frame, %.1f fps)\n", recorder.frames(),
                recorder.frames() == 1 ? "" : "s", s.width, s.height, f.output.c_str(),
                recorder.frame_ms_total() / recorder.frames(),
                1000.0 * recorder.frames() / recorder.frame_ms_total());
  }
  if (f.video) encode_video(f.output, f.quiet);
}

}  // namespace

void add_render_command(CLI::App& app) {
  auto flags = std::make_shared<RenderCommandFlags>();
  CLI::App* cmd = app.add_subcommand(
      "render", "Draw a volume headless (EGL): stills, a turntable, or a trace being replayed");
  cmd->add_option("volume", flags->volume, volume_help())->required();
  cmd->add_option("--output,-o", flags->output, "Directory for frame_NNNN.png (created)")
      ->required();
  cmd->add_option("--trace", flags->trace_path, "Replay this trace (lockstep) and draw the tool");
  cmd->add_option("--turntable", flags->turntable, "Frames of a full turn around the volume");
  cmd->add_option("--every-ticks", flags->every_ticks, "With --trace: a frame every N ticks")
      ->capture_default_str();
  cmd->add_flag("--plastic", flags->plastic, "With --trace: sculpt (plasticity and relaxation)");
  cmd->add_flag("--video", flags->video, "Also encode frames.mp4 (needs ffmpeg)");
  cmd->add_flag("--quiet,-q", flags->quiet, "No summary");
  flags->render.add_to(*cmd);
  flags->mapping.add_to(*cmd);
  flags->trace.add_to(*cmd);
  flags->transform.add_to(*cmd);
  flags->force.add_to(*cmd);
  cmd->add_option("--model", flags->model,
                  "Deformation model: voxel (Prados: the FFD press, sculpting) or fem (Nakao: "
                  "the volume as an adaptive tet proxy mesh deforms it; needs --materials)")
      ->capture_default_str();
  add_fem_options(*cmd, flags->fem_mesh);
  flags->fem_run.add_to(*cmd, /*realtime=*/false);
  cmd->callback([flags] { run_render(*flags); });
}

}  // namespace hapvox::cli
