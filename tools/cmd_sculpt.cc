// hapvox sculpt VOLUME [-o SESSION.h5] [--trace-out T.csv] [--script FILE] [--screenshot PNG]:
// a window where the mouse drags the tool over the volume (tools/sculpt_window.h) while the
// force loop runs at 1 kHz beside the relaxation, as `replay --realtime` runs them. On exit
// it writes the session and the trace of the positions its ticks used: `hapvox replay` of
// that trace in lockstep steps the model through the same positions again.

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "engine/errors.h"
#include "haptics/mouse_device.h"
#include "haptics/pointer_script.h"
#include "tools/cli.h"
#include "tools/replay_command.h"
#include "tools/sculpt_window.h"

namespace hapvox::cli {
namespace {

namespace fs = std::filesystem;

struct SculptFlags {
  ReplayFlags replay;
  std::string script;
  std::string screenshot;
  bool elastic = false;
  double fps = 60.0;
  double tool_speed_mm_s = 200.0;
};

void run_sculpt(SculptFlags& flags, const std::string& command_line) {
  ReplayFlags& f = flags.replay;
  if (flags.elastic && f.plastic) throw InputError("--elastic", "cannot go with --plastic");
  f.realtime = true;
  f.plastic = !flags.elastic;
  if (f.trace_out.empty()) f.trace_out = fs::path(f.output).replace_extension(".csv").string();
  if (!(flags.fps > 0.0 && flags.fps <= 240.0)) throw InputError("--fps", "must lie in (0, 240]");
  if (!(flags.tool_speed_mm_s > 0.0) || !std::isfinite(flags.tool_speed_mm_s)) {
    throw InputError("--tool-speed-mm-s", "must be positive");
  }
  // The script and every screenshot it takes, checked before anything runs.
  std::vector<haptics::PointerEvent> script;
  std::vector<InputPath> inputs = volume_inputs(f.volume);
  if (!flags.script.empty()) {
    script = haptics::read_pointer_script(flags.script);
    inputs.push_back({flags.script, "--script"});
  }
  std::vector<OutputPath> outputs;
  if (!flags.screenshot.empty()) {
    if (fs::path(flags.screenshot).extension() != ".png") {
      throw InputError("--screenshot", "must name a .png file");
    }
    check_output_path(flags.screenshot, "--screenshot");
    outputs.push_back({flags.screenshot, "--screenshot", ""});
  }
  for (const haptics::PointerEvent& e : script) {
    if (e.kind != haptics::PointerEvent::Kind::kScreenshot) continue;
    check_output_path(e.path, flags.script);
    outputs.push_back({e.path, flags.script, ""});
  }
  check_outputs_spare_inputs(outputs, inputs);

  std::unique_ptr<SculptWindow> window;
  haptics::MouseDevice* mouse = nullptr;
  LiveFrontEnd front_end;
  front_end.name = "mouse";
  front_end.make_device = [&](const engine::DensityField& field, double tool_radius_mm) {
    // The tool starts above the middle of the volume's top, clear of it.
    const Eigen::Vector3d lo = field.world_min_mm(), hi = field.world_max_mm();
    haptics::MouseDeviceOptions options;
    options.rate_hz = f.trace.rate_hz;
    options.max_speed_mm_s = flags.tool_speed_mm_s;
    options.start_mm = Eigen::Vector3d(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()),
                                       hi.z() + tool_radius_mm + 2.0);
    auto device = std::make_unique<haptics::MouseDevice>(options);
    mouse = device.get();
    return std::unique_ptr<haptics::Device>(std::move(device));
  };
  front_end.make_render_loop = [&](const engine::DensityField& field, haptics::Device&,
                                   double tool_radius_mm) {
    const RenderSetup setup = resolve_render_flags(f.render, f.volume, field, "render-");
    SculptWindowOptions options;
    options.width = setup.settings.width;
    options.height = setup.settings.height;
    options.fps = flags.fps;
    options.tool_radius_mm = tool_radius_mm;
    options.model_label = f.plastic ? "voxel, plastic" : "voxel, elastic";
    options.script = script;
    options.screenshot = flags.screenshot;
    window = std::make_unique<SculptWindow>(field, setup, *mouse, options);
    return window->loop();
  };
  f.front_end = &front_end;
  end_session_on_signals();  // Ctrl-C in the terminal ends the session as Escape does
  run_replay(f, command_line);
  const SculptWindowReport& report = window->report();
  std::printf("  window           %d frames, %d strokes (%d picked nothing)\n", report.frames,
              report.presses, report.picks_missed);
  for (const std::string& path : report.screenshots) {
    std::printf("  screenshot       %s\n", path.c_str());
  }
  std::printf(
      "  trace            %s (hapvox replay %s --volume %s%s: the same ticks in "
      "lockstep)\n",
      f.trace_out.c_str(), f.trace_out.c_str(), f.volume.c_str(), f.plastic ? " --plastic" : "");
}

}  // namespace

void add_sculpt_command(CLI::App& app) {
  auto flags = std::make_shared<SculptFlags>();
  CLI::App* cmd = app.add_subcommand(
      "sculpt",
      "Open a window where the mouse drags the tool over a volume: the force loop at 1 kHz, "
      "the clay sculpted and relaxed beside it; writes the session and its trace on exit");
  cmd->add_option("volume", flags->replay.volume, volume_help())->required();
  cmd->add_option("--output,-o", flags->replay.output, "Session file to write (.h5)")
      ->capture_default_str();
  flags->replay.output = "sculpt_session.h5";
  cmd->add_option("--trace-out", flags->replay.trace_out,
                  "The positions the session's ticks used, as a CSV trace (default: the "
                  "session's name with .csv)");
  cmd->add_option("--script", flags->script,
                  "Drive the window from a file of timed pointer and key events instead of "
                  "(or beside) a person (docs/formats.md: Sculpt scripts)");
  cmd->add_option("--screenshot", flags->screenshot, "Write the window's last frame to a PNG");
  cmd->add_option("--sculpt-out", flags->replay.sculpt_out,
                  "Write the sculpted volume as PREFIX.vdb and PREFIX.nrrd on exit");
  cmd->add_flag("--elastic", flags->elastic,
                "Feel the volume without sculpting it (default: plastic, the clay flows)");
  cmd->add_option("--fps", flags->fps, "The window's frame rate")->capture_default_str();
  cmd->add_option("--tool-speed-mm-s", flags->tool_speed_mm_s,
                  "How fast the tool follows the cursor")
      ->capture_default_str();
  flags->replay.render.size = "800x600";
  add_replay_flags(cmd, &flags->replay, false);
  cmd->callback([flags] { run_sculpt(*flags, command_line()); });
}

}  // namespace hapvox::cli
