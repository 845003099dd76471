// hapvox sculpt VOLUME [-o SESSION.h5] [--trace-out T.csv] [--script FILE] [--screenshot PNG]:
// a window where the mouse drags the tool over the volume (tools/sculpt_window.h) while the
// force loop runs at 1 kHz beside the relaxation, as `replay --realtime` runs them. On exit
// it writes the session and the trace of the positions its ticks used: `hapvox replay` of
// that trace in lockstep steps the model through the same positions again. With --device
// udp:HOST:PORT a device program moves the tool through the bridge and the window watches.
//
// Keys that change the tool ([ ]), the clay's plasticity (p) or undo a stroke (z) end a
// segment: each segment is one realtime run with its own session, trace and starting clay
// (NAME-K.h5, NAME-K.csv, NAME-K-start.vdb), so each replays in lockstep on its own. Undo
// replays the stroke's segment in lockstep up to the tick the stroke began: the clay the
// next segment starts from is exactly the clay before the stroke.
//
// With --materials, m switches between the voxel model and Nakao's proxy-mesh FEM (--model
// fem starts with it): a FEM segment presses the clay as it is, the FEM paced in lockstep
// with the force loop, and replays with `replay --model fem --no-tool-refine`.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include "engine/errors.h"
#include "engine/volume_io.h"
#include "haptics/mesh_file.h"
#include "haptics/mouse_device.h"
#include "haptics/pointer_script.h"
#include "haptics/trace.h"
#include "haptics/watched_device.h"
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

// NAME.EXT for segment 1, NAME-K.EXT for segment K.
std::string segment_path(const std::string& path, int k) {
  if (k == 1) return path;
  const fs::path p(path);
  return (p.parent_path() / (p.stem().string() + "-" + std::to_string(k) + p.extension().string()))
      .string();
}

// The clay segment K starts from: NAME-K-start.vdb (and .nrrd beside it).
std::string start_prefix(const std::string& output, int k) {
  const fs::path p(output);
  return (p.parent_path() / (p.stem().string() + "-" + std::to_string(k) + "-start")).string();
}

// The tool's diameter after [ or ]: a quarter smaller or larger, to 0.1 mm (so the replay
// command's --tool-diameter-mm reads back the same double), within [1, 40] mm.
double next_diameter_mm(double diameter_mm, SegmentEnd key) {
  const double scaled = key == SegmentEnd::kLargerTool ? diameter_mm * 1.25 : diameter_mm / 1.25;
  return std::clamp(std::round(scaled * 10.0) / 10.0, 1.0, 40.0);
}

const char* end_name(SegmentEnd end) {
  switch (end) {
    case SegmentEnd::kSmallerTool:
      return "[ (a smaller tool)";
    case SegmentEnd::kLargerTool:
      return "] (a larger tool)";
    case SegmentEnd::kTogglePlastic:
      return "p (plastic on/off)";
    case SegmentEnd::kUndo:
      return "z (undo)";
    case SegmentEnd::kSwitchModel:
      return "m (the voxel or FEM model)";
    case SegmentEnd::kQuit:
      break;
  }
  return "the end of the session";
}

// One realtime run of the session.
struct Segment {
  std::string output, trace, volume;
  double diameter_mm = 0.0;
  bool plastic = true;
  SegmentEnd end = SegmentEnd::kQuit;
  bool fem = false;  // the proxy-mesh FEM model (else the voxel model)
};

// The flags a segment's trace replays with, after TRACE --volume VOLUME.
std::string replay_flags(const Segment& s) {
  char diameter[48];
  std::snprintf(diameter, sizeof diameter, " --tool-diameter-mm %g", s.diameter_mm);
  return std::string(s.fem       ? " --model fem --no-tool-refine"
                     : s.plastic ? " --plastic"
                                 : "") +
         diameter;
}

const char* model_name(const Segment& s) {
  return s.fem ? "FEM (proxy mesh)" : s.plastic ? "plastic" : "elastic";
}

// A plastic stroke not undone: its segment's starting clay, trace and tool, and the tick the
// stroke began at.
struct Stroke {
  int segment = 0;
  std::string volume, trace;
  double diameter_mm = 0.0;
  std::int64_t press_tick = 0;
};

// The clay before `stroke`: its segment replayed in lockstep up to the tick it began, the
// flows in flight finished, written as PREFIX.vdb and .nrrd. Returns the .vdb (or the
// segment's own start when the stroke began on its first ticks).
std::string clay_before(const Stroke& stroke, const ReplayFlags& f, const std::string& prefix,
                        const std::string& command_line) {
  haptics::Trace trace = haptics::read_trace(stroke.trace, f.trace.columns());
  const std::size_t ticks = static_cast<std::size_t>(stroke.press_tick);
  if (ticks < 2 || trace.time_s.size() < 2) return stroke.volume;  // nothing ran before it
  trace.time_s.resize(std::min(ticks, trace.time_s.size()));
  trace.position_mm.resize(trace.time_s.size());
  if (!trace.orientation.empty()) trace.orientation.resize(trace.time_s.size());
  ReplayFlags undo = f;
  undo.front_end = nullptr;
  undo.realtime = false;
  undo.trace_out.clear();
  undo.trace_path = prefix + ".csv";
  undo.output = prefix + ".h5";
  undo.sculpt_out = prefix;
  undo.volume = stroke.volume;
  undo.plastic = true;
  undo.quiet = true;
  undo.force.options.tool.diameter_mm = stroke.diameter_mm;
  haptics::write_csv_trace(trace, undo.trace_path);
  std::printf(
      "undo: the clay before the stroke at tick %lld of segment %d (%s's first %zu "
      "ticks in lockstep)\n",
      static_cast<long long>(stroke.press_tick), stroke.segment, stroke.trace.c_str(),
      trace.time_s.size());
  run_replay(undo, command_line);
  fs::remove(undo.trace_path);
  fs::remove(undo.output);
  return prefix + ".vdb";
}

void print_segments(const std::vector<Segment>& segments) {
  std::printf(
      "  segments         %zu, each replayed in lockstep on its own (with sculpt's force "
      "and FEM flags):\n",
      segments.size());
  for (std::size_t i = 0; i < segments.size(); ++i) {
    const Segment& s = segments[i];
    std::printf(
        "    %zu  %s: tool %.1f mm, %s, ended by %s\n       hapvox replay %s --volume "
        "%s%s\n",
        i + 1, s.output.c_str(), s.diameter_mm, model_name(s), end_name(s.end), s.trace.c_str(),
        s.volume.c_str(), replay_flags(s).c_str());
  }
}

void run_sculpt(SculptFlags& flags, const std::string& command_line) {
  ReplayFlags& f = flags.replay;
  if (flags.elastic && f.plastic) throw InputError("--elastic", "cannot go with --plastic");
  if (flags.elastic && !f.sculpt_out.empty()) throw InputError("--sculpt-out", "needs --plastic");
  if (f.model != "voxel" && f.model != "fem") {
    throw InputError("--model", "unknown model '" + f.model + "' (voxel or fem)");
  }
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
  if (!f.sculpt_out.empty()) {
    check_output_path(f.sculpt_out + ".vdb", "--sculpt-out");
    outputs.push_back({f.sculpt_out + ".vdb", "--sculpt-out", ""});
    outputs.push_back({f.sculpt_out + ".nrrd", "--sculpt-out", ""});
  }
  check_outputs_spare_inputs(outputs, inputs);
  // What segment K writes: its session, trace (and a FEM segment's .xdmf), and the clay
  // segment K+1 starts from.
  auto check_segment_outputs = [&](int k) {
    const std::string next = start_prefix(f.output, k + 1);
    check_outputs_spare_inputs({{segment_path(f.output, k), "--output", ""},
                                {haptics::xdmf_path_for(segment_path(f.output, k)), "--output", ""},
                                {segment_path(f.trace_out, k), "--trace-out", ""},
                                {next + ".vdb", "--output", ""},
                                {next + ".nrrd", "--output", ""},
                                {next + ".csv", "--output", ""},  // an undo's, removed
                                {next + ".h5", "--output", ""}},
                               inputs);
  };
  check_segment_outputs(1);

  std::unique_ptr<SculptWindow> window;
  haptics::MouseDevice* mouse = nullptr;          // the window moves the tool
  haptics::WatchedDevice* watched = nullptr;      // the mouse, or the bridge watched
  std::unique_ptr<haptics::BridgeDevice> bridge;  // --device: a device program moves it
  std::optional<Eigen::Vector3d> start_mm;        // where the next segment's tool starts
  std::string model_label;
  bool can_undo = false;
  bool segment_plastic = f.plastic;
  bool segment_fem = false;
  const bool can_switch_model = !f.fem_mesh.materials.empty();  // the FEM model needs one
  LiveFrontEnd front_end;
  front_end.name = f.device.empty() ? "mouse" : f.device;
  front_end.make_device = [&](const engine::DensityField& field, double tool_radius_mm) {
    // The tool starts above the middle of the volume's top, clear of it; a later segment
    // where the last one left it (a device program's tool: wherever it sends it first).
    front_end.start_mm = start_mm ? *start_mm : above_volume_mm(field, tool_radius_mm);
    if (!f.device.empty()) {
      bridge = make_bridge_device(f, f.transform.resolve_fixed());
      front_end.bridge = bridge.get();
      auto device = std::make_unique<haptics::ObservedDevice>(*bridge);
      watched = device.get();
      return std::unique_ptr<haptics::Device>(std::move(device));
    }
    haptics::MouseDeviceOptions options;
    options.rate_hz = f.trace.rate_hz;
    options.max_speed_mm_s = flags.tool_speed_mm_s;
    options.start_mm = front_end.start_mm;
    auto device = std::make_unique<haptics::MouseDevice>(options);
    mouse = device.get();
    watched = mouse;
    return std::unique_ptr<haptics::Device>(std::move(device));
  };
  front_end.make_render_loop = [&](const engine::DensityField& field, haptics::Device&,
                                   double tool_radius_mm) {
    if (!window) {
      const RenderSetup setup = resolve_render_flags(f.render, f.volume, field, "render-");
      SculptWindowOptions options;
      options.width = setup.settings.width;
      options.height = setup.settings.height;
      options.fps = flags.fps;
      options.script = script;
      options.screenshot = flags.screenshot;
      window = std::make_unique<SculptWindow>(field, setup, options);
    }
    SculptSegmentSetup segment;
    segment.tool_radius_mm = tool_radius_mm;
    segment.model_label = model_label;
    segment.plastic = segment_plastic;
    segment.can_undo = can_undo;
    segment.proxy_mesh = segment_fem;
    segment.can_toggle_plastic = !segment_fem;
    segment.can_switch_model = can_switch_model;
    segment.device_label = front_end.name;
    return window->loop(field, *watched, mouse, segment);
  };
  end_session_on_signals();  // Ctrl-C in the terminal ends the session as Escape does

  std::vector<Segment> segments;
  std::vector<Stroke> strokes;  // plastic strokes not undone, in order
  std::string volume = f.volume;
  double diameter_mm = f.force.options.tool.diameter_mm;
  bool plastic = f.plastic;  // the voxel model's segments sculpt
  bool fem = f.model == "fem";
  for (int k = 1;; ++k) {
    if (k > 1) check_segment_outputs(k);
    ReplayFlags run = f;
    run.front_end = &front_end;
    run.volume = volume;
    run.model = fem ? "fem" : "voxel";
    run.plastic = plastic && !fem;
    run.no_tool_refine = true;
    run.fem_only_options.clear();  // the FEM flags are for its segments: kept, not refused
    run.force.options.tool.diameter_mm = diameter_mm;
    run.output = segment_path(f.output, k);
    run.trace_out = segment_path(f.trace_out, k);
    run.sculpt_out = run.plastic ? start_prefix(f.output, k + 1) : "";
    model_label = fem           ? "FEM (proxy mesh), press"
                  : run.plastic ? "voxel, plastic"
                                : "voxel, elastic";
    segment_plastic = run.plastic;
    segment_fem = fem;
    can_undo = !strokes.empty();
    run_replay(run, command_line);
    const SculptSegmentReport& report = window->segment();
    segments.push_back(
        {run.output, run.trace_out, volume, diameter_mm, run.plastic, report.end, fem});
    if (run.plastic) {
      for (const std::int64_t tick : report.press_ticks) {
        strokes.push_back({k, volume, run.trace_out, diameter_mm, tick});
      }
      volume = run.sculpt_out + ".vdb";
    }
    if (report.end == SegmentEnd::kQuit || stop_request()->load()) break;
    const double old_diameter_mm = diameter_mm;
    switch (report.end) {
      case SegmentEnd::kSmallerTool:
      case SegmentEnd::kLargerTool:
        diameter_mm = next_diameter_mm(diameter_mm, report.end);
        break;
      case SegmentEnd::kTogglePlastic:
        plastic = !plastic;
        break;
      case SegmentEnd::kSwitchModel:
        fem = !fem;
        break;
      case SegmentEnd::kUndo:
        if (!strokes.empty()) {
          const std::string next = start_prefix(f.output, k + 1);
          volume = clay_before(strokes.back(), f, next, command_line);
          strokes.pop_back();
          if (volume != next + ".vdb") {  // this segment's end clay is no one's start
            fs::remove(next + ".vdb");
            fs::remove(next + ".nrrd");
          }
        }
        break;
      case SegmentEnd::kQuit:
        break;
    }
    // The next segment's tool starts where this one's was (the trace goes on from there),
    // backed off along the view by what a larger tool grew.
    start_mm = report.last_position_mm -
               std::max(0.0, 0.5 * (diameter_mm - old_diameter_mm)) * report.view_direction;
  }
  window->close();

  // The clay at the end: --sculpt-out gets it; the last segment's unused start files go.
  const Segment& last = segments.back();
  const std::string last_next = start_prefix(f.output, static_cast<int>(segments.size()) + 1);
  if (!f.sculpt_out.empty()) {
    if (volume == f.volume) {
      const engine::DensityField clay = engine::load_volume(f.volume, f.mapping.resolve());
      engine::write_vdb(clay, f.sculpt_out + ".vdb");
      engine::write_nrrd(clay, f.sculpt_out + ".nrrd");
    } else {
      const std::string prefix = volume.substr(0, volume.size() - 4);  // less ".vdb"
      for (const char* ext : {".vdb", ".nrrd"}) {
        fs::copy_file(prefix + ext, f.sculpt_out + ext, fs::copy_options::overwrite_existing);
      }
    }
  }
  if (last.plastic) {
    fs::remove(last_next + ".vdb");
    fs::remove(last_next + ".nrrd");
  }

  const SculptWindowReport& report = window->report();
  std::printf("  window           %d frames, %d strokes (%d picked nothing), %d FEM steps drawn\n",
              report.frames, report.presses, report.picks_missed, report.fem_steps_drawn);
  for (const std::string& path : report.screenshots) {
    std::printf("  screenshot       %s\n", path.c_str());
  }
  if (segments.size() == 1) {
    std::printf(
        "  trace            %s (hapvox replay %s --volume %s%s: the same ticks in "
        "lockstep)\n",
        f.trace_out.c_str(), f.trace_out.c_str(), f.volume.c_str(),
        replay_flags(segments.front()).c_str());
  } else {
    print_segments(segments);
  }
  if (!f.sculpt_out.empty()) {
    std::printf("  sculpted volume  %s.vdb, %s.nrrd\n", f.sculpt_out.c_str(), f.sculpt_out.c_str());
  }
}

}  // namespace

void add_sculpt_command(CLI::App& app) {
  auto flags = std::make_shared<SculptFlags>();
  CLI::App* cmd = app.add_subcommand(
      "sculpt",
      "Open a window where the mouse drags the tool over a volume: the force loop at 1 kHz, "
      "the clay sculpted and relaxed beside it (or, with --materials and the m key or --model "
      "fem, pressed through Nakao's proxy-mesh FEM); writes the session and its trace on exit");
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
