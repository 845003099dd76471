#pragma once
// What `hapvox replay` and `hapvox check-timing` share between the models they run (the
// voxel model in tools/cmd_replay.cc, the proxy FEM in tools/replay_fem.cc): the flags, the
// result, the session attributes every run writes and the lines every run prints.

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "haptics/bridge_device.h"
#include "haptics/fem_model.h"
#include "haptics/realtime.h"
#include "haptics/voxel_model.h"
#include "tools/cli.h"
#include "tools/fem_options.h"
#include "tools/render_output.h"

namespace hapvox::cli {

/// What `hapvox sculpt` (tools/cmd_sculpt.cc) puts where a replay has its trace: a device
/// a window drives, and the window as the realtime loop's render loop.
struct LiveFrontEnd {
  std::string name;  // the session's "device" attribute, e.g. "mouse"
  /// The device, once the volume is loaded and the tool known.
  std::function<std::unique_ptr<haptics::Device>(const engine::DensityField& field,
                                                 double tool_radius_mm)>
      make_device;
  /// The render loop for `device`, made before the session file (a machine without a display
  /// fails before any output).
  std::function<haptics::RenderLoop(const engine::DensityField& field, haptics::Device& device,
                                    double tool_radius_mm)>
      make_render_loop;
  /// With --device: the bridge behind the window's device, set by make_device (its counts
  /// go in the session and the report as a `replay --device` run's do).
  const haptics::BridgeDevice* bridge = nullptr;
  /// Where the tool starts (volume mm), set by make_device: the FEM model's first snapshot
  /// is made there, as a trace replay's is at the trace's first position.
  Eigen::Vector3d start_mm = Eigen::Vector3d::Zero();
};

struct ReplayFlags {
  std::string trace_path;
  std::string device;  // --device udp:HOST:PORT: a live device through the bridge
  const LiveFrontEnd* front_end = nullptr;  // sculpt: a window's device instead of either
  std::string trace_out;    // --trace-out T.csv: the positions a live session's ticks used
  std::string device_peer;  // --device-peer HOST:PORT: the one sender --device takes
  std::string device_key;   // --device-key FILE: the bridge's shared key (HMAC tags)
  double silence_timeout_s = 0.01;
  double end_after_silence_s = 5.0;
  std::string volume;
  std::string output;
  bool quiet = false;
  // The report on stdout after the run (and its warnings on stderr); the API's replay
  // (api/replay.cc) prints nothing.
  bool print_report = true;
  MappingFlags mapping;
  TraceFlags trace;
  TransformFlags transform;
  ForceFlags force;
  haptics::DeviceLimits limits;
  // Sculpting.
  bool plastic = false;
  bool realtime = false;
  std::size_t relax_voxels_per_tick = 2000;
  double relax_tolerance = 0.02;
  double normal_density = 1.0;
  std::string sculpt_out;
  // Realtime scheduling.
  bool no_mlock = false;
  bool no_rt_priority = false;
  int cpu = -1;
  bool no_pin = false;
  double watchdog_ms = haptics::kDefaultWatchdogMs;
  double watchdog_periods = 0.0;  // > 0: --watchdog-periods, in place of --watchdog-ms
  // The deformation model: "voxel" (Prados) or "fem" (Nakao's proxy mesh).
  std::string model = "voxel";
  FemCliOptions fem_mesh;             // --materials, --labels, --seed, ...
  FemRunFlags fem_run;                // --interaction, --fem-solver, --coupling-n-per-mm, ...
  std::vector<std::string> relabels;  // --relabel T_S:FROM=TO (tools/relabel.h)
  // --no-tool-refine: the proxy mesh is not refined along the trace's tool path (as in a
  // sculpt session's FEM segments, whose path is not known ahead).
  bool no_tool_refine = false;
  // The options only --model fem reads (owned by the command's CLI::App): refused with
  // --model voxel when given, rather than silently ignored.
  std::vector<const CLI::Option*> fem_only_options;
  // Rendering (a render thread in realtime, a frame every N ticks in lockstep).
  std::string render_dir;
  double render_fps = 30.0;
  std::size_t render_every_ticks = 100;
  RenderFlags render;
};

// What a replay measured, for the caller to judge.
struct ReplayResult {
  haptics::ReplaySummary summary;
  haptics::TimingSummary timing;
  haptics::SculptSummary sculpted;
};

/// `replay --model fem` (tools/replay_fem.cc).
ReplayResult run_fem_replay(const ReplayFlags& f, const std::string& command_line);

/// `hapvox replay` (and check-timing, and sculpt through f.front_end): the run, the session,
/// the report (tools/cmd_replay.cc).
ReplayResult run_replay(const ReplayFlags& f, const std::string& command_line);

/// The voxel model's force options from the flags, checked as `hapvox replay` checks them
/// (material, tool, plasticity, relaxation tolerance, normal density, contact law):
/// InputError naming the flag.
engine::ToolForceOptions voxel_force_options(const ReplayFlags& f);

/// Adds the `replay` subcommand with every flag of `hapvox replay` bound to `flags` (which
/// must outlive the parse), and no callback: `hapvox replay` and the API (api/) parse the
/// same flags.
CLI::App* add_replay_subcommand(CLI::App& app, ReplayFlags* flags);

/// Registers the replay's flags on `cmd` (the trace positional and --volume with
/// `with_inputs`: sculpt names its volume positionally and has no trace).
void add_replay_flags(CLI::App* cmd, ReplayFlags* flags, bool with_inputs = true);

/// The box the tool's centre sweeps over the trace, grown by `radius_mm`: where the proxy
/// mesh is refined.
Eigen::AlignedBox3d fem_tool_region(const haptics::TraceDevice& device, double radius_mm);

/// A lockstep replay's frames for the proxy-FEM model: at a frame after a FEM step the
/// recorder resamples the volume from the step's displacements (on the mesh they belong
/// to), then draws. `recorder`, `model` and `fem` must outlive the replay.
haptics::LockstepRender fem_lockstep_frames(FrameRecorder& recorder, const haptics::FemModel& model,
                                            const haptics::FemBackgroundStage& fem,
                                            std::size_t every_ticks);

/// Where a live session's tool starts: above the middle of the volume's top, its sphere
/// (of `tool_radius_mm`) 2 mm clear of it (world mm).
Eigen::Vector3d above_volume_mm(const engine::DensityField& field, double tool_radius_mm);

/// --device's flags (tools/replay_bridge.cc); InputError naming the flag (or the key file).
void check_bridge_flags(const ReplayFlags& f);
/// --device-peer's HOST:PORT (or udp:HOST:PORT), resolved. InputError naming the flag.
haptics::SocketAddress resolve_device_peer(const std::string& spec);
/// The bridge device listening on --device; Ctrl-C and SIGTERM end its session cleanly.
std::unique_ptr<haptics::BridgeDevice> make_bridge_device(
    const ReplayFlags& f, const haptics::DeviceTransform& transform);
/// Set by Ctrl-C / SIGTERM once make_bridge_device (or end_session_on_signals) has run.
const std::atomic<bool>* stop_request();
/// Ctrl-C and SIGTERM set stop_request() (a live session then ends cleanly, its files whole).
void end_session_on_signals();

/// For one realtime run: clears stop_request(), makes Ctrl-C and SIGTERM set it, and puts
/// back the handlers it found when it goes (hapvox as a library, e.g. in Python, keeps its
/// application's own handlers between runs).
class StopOnSignals {
 public:
  StopOnSignals();
  ~StopOnSignals();
  StopOnSignals(const StopOnSignals&) = delete;
  StopOnSignals& operator=(const StopOnSignals&) = delete;

 private:
  void (*interrupt_)(int);
  void (*terminate_)(int);
};
void write_bridge_attributes(haptics::SessionWriter& session, const haptics::BridgeDevice& device);
void print_bridge_lines(const haptics::BridgeDevice& device);
/// The trace a live session's ticks used (t = tick / rate, the device-frame positions), as
/// CSV: `hapvox replay` of it in lockstep steps the model through the same positions.
void write_recorded_trace(const std::string& session_path, const std::string& trace_path);

/// What moved the tool: the window's name, the --device address or the trace file.
std::string run_source(const ReplayFlags& f);

/// A run in which no tick ran (a live device that sent nothing, a stop before the first
/// tick) records nothing: throws InputError(run_source(f), "... nothing written to OUT"),
/// which the caller's handler turns into exit 2 after abandoning the session.
/// With the bridge, the line says what it refused (other senders', unauthenticated packets).
void refuse_empty_run(const ReplayFlags& f, const haptics::ReplaySummary& s,
                      const haptics::BridgeDevice* bridged = nullptr);

/// The flags every model checks alike (limits, rates, scheduling); InputError naming the flag.
void check_loop_flags(const ReplayFlags& f);

/// The realtime loop's options from the flags.
haptics::RealtimeOptions realtime_options(const ReplayFlags& f);

/// The progress bar (stderr), when it is shown.
haptics::ProgressFn progress_bar(const ReplayFlags& f, const haptics::Device& device);

/// The attributes of the run itself: command line, trace (null: the live --device), volume,
/// clock, limits, transform, versions.
void write_run_attributes(haptics::SessionWriter& session, const ReplayFlags& f,
                          const std::string& command_line, const haptics::TraceColumns& columns,
                          const engine::IntensityMapping& mapping,
                          const engine::DensityField& field, const haptics::Device& device,
                          const haptics::ResampledTrace* trace);

/// The summary attributes: summary_*, and in realtime the lateness, deadlines, scheduler.
void write_summary_attributes(haptics::SessionWriter& session, const ReplayFlags& f,
                              const haptics::ReplaySummary& s,
                              const haptics::TimingSummary& timing);

/// The report's first lines (ticks, tool, contact, peak force, compute) and in realtime the
/// loop's timing; `compute_note` ends the compute line, e.g. "(812 surface samples)".
void print_run_report(const ReplayFlags& f, const haptics::ReplaySummary& s,
                      const haptics::TimingSummary& timing, const haptics::Device& device,
                      const std::string& compute_note);

/// The report's last lines: trace gaps and non-finite forces.
void print_run_footer(const ReplayFlags& f, const haptics::ReplaySummary& s);

void print_stats_line(const char* label, const haptics::DurationStats& d);

/// The render flags' settings; InputError naming a bad one.
RenderSetup check_render_flags(const ReplayFlags& f, const engine::DensityField& field);

/// With --render-dir: checks --render-fps and --render-every-ticks and makes the recorder
/// (on the render thread's side in realtime), before the session: a machine without EGL fails
/// before any file. Null without --render-dir.
std::unique_ptr<FrameRecorder> make_replay_recorder(const ReplayFlags& f,
                                                    const engine::DensityField& field,
                                                    double tool_radius_mm);

/// render_dir, the frame count and, in realtime, the render thread's rate and frame times.
void write_render_attributes(haptics::SessionWriter& session, const ReplayFlags& f,
                             const FrameRecorder& recorder, const haptics::TimingSummary& timing);

/// The report's render line.
void print_render_line(const ReplayFlags& f, const FrameRecorder& recorder,
                       const haptics::TimingSummary& timing);

}  // namespace hapvox::cli
