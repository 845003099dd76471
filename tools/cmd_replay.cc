// hapvox replay TRACE --volume FILE|GENERATOR -o SESSION.h5
// hapvox check-timing TRACE --volume FILE|GENERATOR [budgets]: a realtime replay that
// exits 3, saying why, when the loop broke a timing budget (2: bad input, 1: internal error).

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>

#include "engine/errors.h"
#include "haptics/realtime.h"
#include "haptics/trace_resample.h"
#include "haptics/voxel_model.h"
#include "tools/cli.h"
#include "tools/render_output.h"
#include "tools/replay_command.h"
#include "tools/tissue_options.h"

namespace hapvox::cli {

engine::ToolForceOptions voxel_force_options(const ReplayFlags& f) {
  engine::validate_material(f.force.options.material, "--youngs-modulus-pa", "--poisson");
  const double diameter = f.force.options.tool.diameter_mm;
  if (!std::isfinite(diameter) || diameter <= 0.0) {
    throw InputError("--tool-diameter-mm", "must be positive");
  }
  if (!(f.relax_tolerance >= 0.0 && f.relax_tolerance <= 10.0)) {
    throw InputError("--relax-tolerance", "must lie in [0, 10]");
  }
  if (!(f.normal_density > 0.0 && f.normal_density <= 1.0)) {
    throw InputError("--normal-density", "must lie in (0, 1] (a fraction of density 1)");
  }
  if (f.normal_density != 1.0 && !f.plastic)
    throw InputError("--normal-density", "needs --plastic");
  if (f.plastic) {
    const auto& plastic = f.force.options.plastic;
    if (!std::isfinite(plastic.yield_stress_pa) || plastic.yield_stress_pa <= 0.0) {
      throw InputError("--yield-stress-pa", "must be positive");
    }
    if (!(plastic.elastoplastic_modulus_pa >= 0.0) ||
        plastic.elastoplastic_modulus_pa >= f.force.options.material.youngs_modulus_pa) {
      throw InputError("--elastoplastic-modulus-pa", "must lie in [0, E)");
    }
  }
  engine::ToolForceOptions force_options = f.force.resolve();
  force_options.plastic.enabled = f.plastic;
  // Sculpted clay settles to its normal density: its nominal surface is at half of that.
  if (!f.force.surface_density_given) force_options.surface_density = 0.5 * f.normal_density;
  return force_options;
}

ReplayResult run_replay(const ReplayFlags& f, const std::string& command_line) {
  const bool live = !f.device.empty() || f.front_end != nullptr;
  if (!f.device.empty()) check_bridge_flags(f);
  if (f.device.empty() && !f.device_peer.empty()) {
    throw InputError("--device-peer", "needs --device (the bridge's one sender)");
  }
  if (f.device.empty() && !f.device_key.empty()) {
    throw InputError("--device-key", "needs --device (the bridge's shared key)");
  }
  if (!f.trace_out.empty() && !live) {
    throw InputError("--trace-out", "needs --device (a trace replay has its trace already)");
  }
  if (f.trace_path.empty() && !live) {
    throw InputError("trace", "a trace file is needed (or --device udp:HOST:PORT)");
  }
  if (f.front_end != nullptr && !f.render_dir.empty()) {
    throw InputError("--render-dir", "sculpt draws in its window");
  }
  if (f.model == "fem") return run_fem_replay(f, command_line);
  if (f.model != "voxel")
    throw InputError("--model", "unknown model '" + f.model + "' (voxel or fem)");
  // Check everything the user gave before reading big files or creating output.
  if (!f.fem_run.incision.empty()) throw InputError("--incision", "needs --model fem");
  const bool by_tissue = !f.fem_mesh.materials.empty();
  check_tissue_flags(f.fem_mesh, f.mapping);
  for (const CLI::Option* option : f.fem_only_options) {
    if (option->count() > 0) throw InputError(option->get_name(), "needs --model fem");
  }
  engine::ToolForceOptions force_options = voxel_force_options(f);
  const haptics::TraceColumns columns = f.trace.columns();
  const engine::IntensityMapping mapping = f.mapping.resolve();
  check_loop_flags(f);
  check_output_path(f.output, "--output");
  if (!f.sculpt_out.empty()) {
    if (!f.plastic) throw InputError("--sculpt-out", "needs --plastic");
    check_output_path(f.sculpt_out + ".vdb", "--sculpt-out");
  }
  std::vector<InputPath> inputs = volume_inputs(f.volume);
  if (!live) inputs.push_back({f.trace_path, "trace"});
  for (const InputPath& input : fem_inputs(f.fem_mesh)) inputs.push_back(input);
  if (!f.render_dir.empty()) {
    for (const InputPath& input : transfer_inputs(f.render.transfer)) inputs.push_back(input);
  }
  const std::string& prefix = f.sculpt_out;  // writes PREFIX.vdb and PREFIX.nrrd
  check_outputs_spare_inputs({{f.output, "--output", ""},
                              {f.trace_out, "--trace-out", ""},
                              {prefix.empty() ? "" : prefix + ".vdb", "--sculpt-out", ""},
                              {prefix.empty() ? "" : prefix + ".nrrd", "--sculpt-out", ""},
                              {f.render_dir, "--render-dir", kFrameFileNames}},
                             inputs);
  // Materials by tissue: the labels give each voxel its density and material.
  std::optional<engine::labels::TissueVolume> tissue;
  if (by_tissue) {
    tissue = tissue_volume_from_cli(f.volume, f.fem_mesh, force_options);
  }
  engine::DensityField field =
      tissue ? std::move(tissue->field) : engine::load_volume(f.volume, mapping);
  // Realtime sculpting: the force thread reads one of two buffers the relaxation updates.
  // Sculpting in a window runs the relaxation in lockstep, paced by the clock
  // (RealtimeOptions::background_in_lockstep): its trace replays it bit for bit.
  const bool paced = f.front_end != nullptr;
  std::unique_ptr<haptics::DoubleBufferedField> buffers;
  if (f.realtime && f.plastic && !paced) {
    buffers = std::make_unique<haptics::DoubleBufferedField>(field);
  }
  const engine::ToolForceModel model(buffers ? buffers->buffer(0) : field, force_options,
                                     tissue ? &tissue->tissue : nullptr);
  // The device: a replayed trace, or a live one behind the bridge (bound here, before any
  // file is made: a port in use is one line).
  std::unique_ptr<haptics::TraceDevice> traced;
  std::unique_ptr<haptics::BridgeDevice> bridge;
  std::unique_ptr<haptics::Device> fronted;  // sculpt's window device
  std::vector<std::string> warnings;
  const double tool_radius_mm = 0.5 * model.options().tool.diameter_mm;
  if (f.front_end != nullptr) {
    fronted = f.front_end->make_device(field, tool_radius_mm);
  } else if (live) {
    bridge = make_bridge_device(f, f.transform.resolve_fixed());
  } else {
    const haptics::Trace trace = haptics::read_trace(f.trace_path, columns);
    haptics::ResampleOptions resample_options;
    resample_options.rate_hz = f.trace.rate_hz;
    resample_options.max_gap_s = f.trace.max_gap_s;
    traced = std::make_unique<haptics::TraceDevice>(
        haptics::resample(trace, resample_options, f.trace_path),
        f.transform.resolve(trace, field));
    warnings = replay_warnings(f.trace_path, model, *traced);
  }
  haptics::Device& device = fronted  ? *fronted
                            : bridge ? static_cast<haptics::Device&>(*bridge)
                                     : *traced;

  // The render output before the session: a machine without EGL (or a window without a
  // display) fails before any file.
  std::unique_ptr<FrameRecorder> recorder = make_replay_recorder(f, field, tool_radius_mm);
  haptics::RenderLoop window_loop;
  if (f.front_end != nullptr) {
    window_loop = f.front_end->make_render_loop(field, device, tool_radius_mm);
  }
  haptics::SessionWriter session(f.output);
  write_run_attributes(session, f, command_line, columns, mapping, field, device,
                       traced ? &traced->trace() : nullptr);

  if (tissue) write_tissue_attributes(session, f.fem_mesh.materials, tissue->tissue);
  session.set_attribute("plastic", std::int64_t{f.plastic ? 1 : 0});
  if (f.plastic) {
    session.set_attribute("yield_stress_pa", force_options.plastic.yield_stress_pa);
    session.set_attribute("elastoplastic_modulus_pa",
                          force_options.plastic.elastoplastic_modulus_pa);
    session.set_attribute("relax_voxels_per_tick",
                          static_cast<std::int64_t>(f.relax_voxels_per_tick));
    session.set_attribute("relax_tolerance", f.relax_tolerance);
    session.set_attribute("relax_schedule", std::string(paced ? "lockstep, paced by the clock"
                                                        : f.realtime ? "own thread, in slices"
                                                                     : "lockstep"));
    session.set_attribute("normal_density", f.normal_density);
    session.set_attribute("normal_density_units",
                          std::int64_t{engine::normal_density_units(f.normal_density)});
  }
  // The voxel model's stages (haptics/voxel_model.h); the loops see only their seams.
  std::unique_ptr<engine::MassGrid> mass;
  haptics::SurfaceChangeChannel channel;
  haptics::VoxelForceStage force(model, f.plastic ? &channel : nullptr, buffers.get());
  std::unique_ptr<haptics::RelaxationStage> relaxation;
  haptics::SculptSummary sculpted;
  haptics::TimingSummary timing;
  if (f.plastic) {
    engine::RelaxOptions relax_options;
    relax_options.tolerance = f.relax_tolerance;
    relax_options.normal_density = f.normal_density;
    mass = std::make_unique<engine::MassGrid>(field, relax_options);
    haptics::RelaxBudget budget;
    budget.relax_voxels = f.relax_voxels_per_tick;
    relaxation =
        f.realtime && !paced
            ? std::make_unique<haptics::RelaxationStage>(*mass, channel, *buffers, budget)
            : std::make_unique<haptics::RelaxationStage>(*mass, channel, field, force, budget);
  }
  force.write_attributes(session);

  // The bridge, ours or behind a window's device (sculpt --device).
  const haptics::BridgeDevice* bridged = bridge                   ? bridge.get()
                                         : f.front_end != nullptr ? f.front_end->bridge
                                                                  : nullptr;
  haptics::ReplaySummary s;
  try {
    const haptics::ProgressFn progress = progress_bar(f, device);
    if (f.realtime) {
      haptics::RealtimeOptions options = realtime_options(f);
      // Ctrl-C or SIGTERM ends any realtime run after the tick under way, and the session
      // is finished with every tick it ran.
      const StopOnSignals stop_on_signals;
      options.stop = stop_request();
      options.background_in_lockstep = paced;
      if (recorder) {
        options.render_loop = recorder->realtime_loop(f.render_fps);
        options.scheduler.lock_future_memory = false;
      }
      if (window_loop) {
        options.render_loop = window_loop;
        options.scheduler.lock_future_memory = false;
      }
      s = haptics::replay_realtime(force, relaxation.get(), device, f.limits, &session, progress,
                                   &sculpted, &timing, options);
    } else {
      haptics::LockstepRender render;
      render.every_ticks = f.render_every_ticks;
      if (recorder) {
        render.frame = [&](std::size_t, const haptics::RenderToolState& tool) {
          recorder->draw(tool);
        };
        render.voxel_changed = [&](const openvdb::Coord& ijk, float rho) {
          recorder->set_voxel(ijk, rho);
        };
      }
      s = haptics::replay_lockstep(force, relaxation.get(), device, f.limits, &session, progress,
                                   &sculpted, recorder ? &render : nullptr);
    }
    refuse_empty_run(f, s, bridged);  // abandons the session below
  } catch (...) {
    session.abandon();
    throw;
  }
  write_summary_attributes(session, f, s, timing);
  if (bridged != nullptr) write_bridge_attributes(session, *bridged);
  if (f.realtime && f.plastic) {
    session.set_attribute("summary_relax_slice_p50_us", timing.relax_slice.p50_us);
    session.set_attribute("summary_relax_slice_p99_us", timing.relax_slice.p99_us);
    session.set_attribute("summary_relax_slice_max_us", timing.relax_slice.max_us);
    session.set_attribute("summary_relax_busy_fraction", timing.relax_busy_fraction);
    session.set_attribute("summary_relax_cpu_s", timing.relax_cpu_s);
    session.set_attribute("summary_relax_fifo_demotions",
                          static_cast<std::int64_t>(timing.relax_fifo_demotions));
    session.write_array("timing/relax_slice_ns", timing.relax_slice_ns, "ns");
    session.write_array("timing/relax_slice_start_ns", timing.relax_slice_start_ns, "ns");
  }
  if (recorder) write_render_attributes(session, f, *recorder, timing);
  if (f.plastic) {
    session.set_attribute("summary_plastic_events",
                          static_cast<std::int64_t>(sculpted.plastic_events));
    session.set_attribute("summary_initial_mass_units", sculpted.initial_mass_units);
    session.set_attribute("summary_final_mass_units", sculpted.final_mass_units);
    session.set_attribute("summary_queue_overflows",
                          static_cast<std::int64_t>(sculpted.queue_overflows));
  }
  session.close();
  if (!f.trace_out.empty()) write_recorded_trace(f.output, f.trace_out);
  if (!f.sculpt_out.empty()) {
    const engine::DensityField sculpted_field = mass->to_density_field();
    engine::write_vdb(sculpted_field, f.sculpt_out + ".vdb");
    engine::write_nrrd(sculpted_field, f.sculpt_out + ".nrrd");
  }

  if (f.print_report) {
    const std::string source = run_source(f);
    std::printf("%s %s on %s -> %s\n", f.front_end ? "sculpted with" : "replayed", source.c_str(),
                f.volume.c_str(), f.output.c_str());
    print_run_report(f, s, timing, device,
                     "(" + std::to_string(model.surface_sample_count()) + " surface samples)");
    if (f.realtime && f.plastic) {
      print_stats_line("relax slices", timing.relax_slice);
      std::printf("  relax thread     busy %.1f%% of the wall time, %.3f s CPU%s\n",
                  100.0 * timing.relax_busy_fraction, timing.relax_cpu_s,
                  timing.relax_fifo_demotions == 0
                      ? ""
                      : (", " + std::to_string(timing.relax_fifo_demotions) +
                         " steps down from SCHED_FIFO (over 75% busy for 200 ms)")
                            .c_str());
    }
    if (f.plastic) {
      std::printf(
          "  plastic          %llu events, %llu voxels deleted, %llu relaxed, queue max %zu "
          "(%llu overflows coalesced), %s\n",
          static_cast<unsigned long long>(sculpted.plastic_events),
          static_cast<unsigned long long>(sculpted.deleted_voxels),
          static_cast<unsigned long long>(sculpted.relaxed_voxels), sculpted.max_queue_depth,
          static_cast<unsigned long long>(sculpted.queue_overflows),
          sculpted.settled ? "settled" : "still relaxing at the end");
      std::printf("  mass             %lld -> %lld units (%s)\n",
                  static_cast<long long>(sculpted.initial_mass_units),
                  static_cast<long long>(sculpted.final_mass_units),
                  sculpted.initial_mass_units == sculpted.final_mass_units ? "conserved exactly"
                                                                           : "CHANGED");
      if (!f.sculpt_out.empty()) {
        std::printf("  sculpted volume  %s.vdb, %s.nrrd\n", f.sculpt_out.c_str(),
                    f.sculpt_out.c_str());
      }
    }
    if (bridged != nullptr) print_bridge_lines(*bridged);
    if (recorder) print_render_line(f, *recorder, timing);
    print_run_footer(f, s);
    print_warnings(warnings);
  }
  return ReplayResult{s, timing, sculpted};
}

namespace {

// --device and the bridge's flags.
// (sculpt registers its own --trace-out: `with_trace_out` false.)
void add_live_flags(CLI::App* cmd, ReplayFlags* flags, bool with_trace_out) {
  cmd->add_option("--device", flags->device,
                  "udp:HOST:PORT: take the tool from a live device program through the bridge "
                  "(docs/formats.md: Device bridge packets; hapvox device-sim is its reference "
                  "client) instead of a trace; needs --realtime");
  if (with_trace_out) {
    cmd->add_option("--trace-out", flags->trace_out,
                    "--device: write the positions the session's ticks used as a CSV trace "
                    "(replaying it in lockstep steps the model through them again)");
  }
  cmd->add_option("--device-peer", flags->device_peer,
                  "--device: HOST:PORT, the device program's address and port: only its "
                  "packets are taken (default: the first valid sender's, for the session)");
  cmd->add_option("--device-key", flags->device_key,
                  "--device: a file of the shared key's bytes: every packet both ways carries "
                  "an HMAC-SHA256 tag, and one whose tag is wrong or missing is refused "
                  "(hapvox device-sim --device-key)");
  cmd->add_option("--silence-timeout-s", flags->silence_timeout_s,
                  "--device: no position for this long and the force ramps out")
      ->capture_default_str();
  cmd->add_option("--end-after-silence-s", flags->end_after_silence_s,
                  "--device: end the session after this long without a position (0: never)")
      ->capture_default_str();
}

}  // namespace

void add_replay_flags(CLI::App* cmd, ReplayFlags* flags, bool with_inputs) {
  if (with_inputs) {
    cmd->add_option("trace", flags->trace_path, "Trace file (.csv or .h5); or --device");
    cmd->add_option("--volume,-v", flags->volume, volume_help())->required();
  }
  add_live_flags(cmd, flags, with_inputs);
  cmd->add_option("--max-force-n", flags->limits.max_force_n, "Device force limit, N")
      ->capture_default_str();
  cmd->add_option("--ramp-in-s", flags->limits.ramp_in_s, "Force ramp-in time at start, s")
      ->capture_default_str();
  cmd->add_flag("--quiet,-q", flags->quiet, "No progress bar");
  flags->mapping.add_to(*cmd);
  flags->trace.add_to(*cmd);
  flags->transform.add_to(*cmd);
  flags->force.add_to(*cmd);
  cmd->add_option("--render-dir", flags->render_dir,
                  "Render frames of the session to DIR/frame_NNNN.png (a render thread in "
                  "realtime, every --render-every-ticks in lockstep)");
  cmd->add_option("--render-fps", flags->render_fps, "Realtime: the render thread's target rate")
      ->capture_default_str();
  cmd->add_option("--render-every-ticks", flags->render_every_ticks,
                  "Lockstep: a frame every N ticks")
      ->capture_default_str();
  if (with_inputs) flags->render.size = "256";  // frames beside a force loop: small by default
  flags->render.add_to(*cmd, "render-");
  cmd->add_option("--model", flags->model,
                  "Deformation model: voxel (Prados: elastic/plastic forces on the density "
                  "field) or fem (Nakao: an adaptive tet proxy mesh with FEM; needs --materials)")
      ->capture_default_str();
  add_fem_options(*cmd, flags->fem_mesh);
  flags->fem_run.add_to(*cmd);
  cmd->add_option("--relabel", flags->relabels,
                  "fem: T_S:FROM=TO: from T_S s into the trace, label FROM's voxels take label "
                  "TO and the mesh is rebuilt in the background (repeatable)")
      ->allow_extra_args(false);
  if (with_inputs) {
    cmd->add_flag("--no-tool-refine", flags->no_tool_refine,
                  "fem: do not refine the proxy mesh where the trace's tool goes (a sculpt "
                  "session's FEM segments are meshed so: replay their traces with it)");
  }
  for (const char* name :
       {"--spacing-mm", "--boundary-levels", "--interaction", "--fem-solver", "--coupling-n-per-mm",
        "--candidate-margin-mm", "--fem-every-ticks", "--fem-rate-hz", "--fem-steps-kept-mb",
        "--relabel", "--no-tool-refine"}) {
    if (const CLI::Option* option = cmd->get_option_no_throw(name)) {
      flags->fem_only_options.push_back(option);
    }
  }
  cmd->add_flag("--plastic", flags->plastic,
                "Sculpt: incremental plasticity, deletion and progressive relaxation");
  cmd->add_option("--yield-stress-pa", flags->force.options.plastic.yield_stress_pa,
                  "Yield stress sigma_f, Pa: the stress along the push (the mean contact "
                  "pressure under the Hertz law) at which the clay flows")
      ->capture_default_str();
  cmd->add_option("--elastoplastic-modulus-pa",
                  flags->force.options.plastic.elastoplastic_modulus_pa,
                  "Elasto-plastic slope E_ep in [0, E), Pa (> 0: linear hardening)")
      ->capture_default_str();
  cmd->add_option("--relax-voxels-per-tick", flags->relax_voxels_per_tick,
                  "Relaxation budget per 1 kHz tick (lockstep) or per slice of the relaxation "
                  "thread (realtime): voxels relaxed, and 8 flow-to-room visits per voxel")
      ->capture_default_str();
  cmd->add_option("--relax-tolerance", flags->relax_tolerance,
                  "Settled when no voxel exceeds normal density by more than this fraction")
      ->capture_default_str();
  cmd->add_option("--normal-density", flags->normal_density,
                  "Sculpt: the material's normal (rest) density, a fraction in (0, 1] of "
                  "density 1, that relaxation settles voxels back to")
      ->capture_default_str();
  cmd->add_flag("--no-mlock", flags->no_mlock, "Realtime: do not lock memory");
  cmd->add_flag("--no-rt-priority", flags->no_rt_priority,
                "Realtime: do not ask for SCHED_FIFO for the force thread");
  cmd->add_flag("--no-pin", flags->no_pin, "Realtime: do not pin the force thread to a CPU");
  cmd->add_option("--cpu", flags->cpu, "Realtime: CPU for the force thread (-1: the last)")
      ->capture_default_str();
  CLI::Option* watchdog_ms =
      cmd->add_option("--watchdog-ms", flags->watchdog_ms,
                      "Realtime: a tick ending more than this many ms after its deadline trips "
                      "the watchdog: the force ramps down to zero and back over --ramp-in-s "
                      "(less late, it is sent at full scale; docs/realtime.md says why 4)")
          ->capture_default_str();
  cmd->add_option("--watchdog-periods", flags->watchdog_periods,
                  "Realtime: the watchdog's threshold in loop periods instead of ms")
      ->excludes(watchdog_ms);
}

namespace {

struct TimingBudget {
  double max_p99_lateness_us = 250.0;
  double max_miss_rate = 0.005;
  double min_rate_ratio = 0.98;
  // Trips a minute (a stall a device would notice, docs/realtime.md); a rate of ticks
  // instead when --max-watchdog-rate is given.
  double max_watchdog_per_min = 1.0;
  double max_watchdog_rate = -1.0;  // < 0: not given
};

void run_check_timing(ReplayFlags f, const TimingBudget& budget, const std::string& command_line) {
  if (!(budget.max_p99_lateness_us > 0.0)) {
    throw InputError("--max-p99-lateness-us", "must be positive");
  }
  if (!(budget.max_miss_rate >= 0.0 && budget.max_miss_rate <= 1.0)) {
    throw InputError("--max-miss-rate", "must lie in [0, 1]");
  }
  if (!(budget.min_rate_ratio >= 0.0 && budget.min_rate_ratio <= 1.0)) {
    throw InputError("--min-rate-ratio", "must lie in [0, 1]");
  }
  if (!(budget.max_watchdog_per_min >= 0.0)) {
    throw InputError("--max-watchdog-per-min", "must be 0 or more");
  }
  if (budget.max_watchdog_rate > 1.0) {
    throw InputError("--max-watchdog-rate", "must lie in [0, 1]");
  }
  f.realtime = true;
  const ReplayResult r = run_replay(f, command_line);
  const double ticks = static_cast<double>(std::max<std::size_t>(1, r.summary.ticks));
  const double miss_rate = static_cast<double>(r.timing.missed_deadlines) / ticks;
  const double watchdog_rate = static_cast<double>(r.timing.watchdog_trips) / ticks;
  const double rate_ratio = r.timing.achieved_rate_hz / r.timing.rate_hz;
  std::vector<std::string> broken;
  char line[256];
  auto check = [&](bool ok, const char* fmt, double value, double limit) {
    std::snprintf(line, sizeof line, fmt, value, limit);
    std::printf("  %s %s\n", ok ? "ok    " : "BROKEN", line);
    if (!ok) broken.push_back(line);
  };
  std::printf("\ntiming budget\n");
  check(r.timing.lateness.p99_us <= budget.max_p99_lateness_us,
        "p99 lateness %.1f us (budget <= %.1f us)", r.timing.lateness.p99_us,
        budget.max_p99_lateness_us);
  check(miss_rate <= budget.max_miss_rate, "missed deadlines %.4f%% of ticks (budget <= %.4f%%)",
        100.0 * miss_rate, 100.0 * budget.max_miss_rate);
  if (budget.max_watchdog_rate >= 0.0) {
    check(watchdog_rate <= budget.max_watchdog_rate,
          "watchdog trips %.4f%% of ticks (budget <= %.4f%%)", 100.0 * watchdog_rate,
          100.0 * budget.max_watchdog_rate);
  } else {
    // Counted over the minutes begun: a run shorter than a minute may have the budget's
    // trips, not a share of one.
    const double minutes = std::max(1.0, std::ceil(r.timing.wall_time_s / 60.0));
    check(static_cast<double>(r.timing.watchdog_trips) <= budget.max_watchdog_per_min * minutes,
          "watchdog trips %.0f (budget <= %.2f: a minute, over the minutes begun)",
          static_cast<double>(r.timing.watchdog_trips), budget.max_watchdog_per_min * minutes);
  }
  check(rate_ratio >= budget.min_rate_ratio, "achieved rate %.4f of target (budget >= %.4f)",
        rate_ratio, budget.min_rate_ratio);
  // A shared machine can stall the whole process: say so, so nobody chases a phantom.
  const double cpu_share =
      r.timing.wall_time_s > 0 ? r.timing.force_cpu_s / r.timing.wall_time_s : 0;
  std::printf("  force thread CPU %.3f s of %.3f s wall (%.0f%%, sleeping is normal)\n",
              r.timing.force_cpu_s, r.timing.wall_time_s, 100.0 * cpu_share);
  if (r.timing.machine_steal_s > 0.001 || r.timing.force_involuntary_switches > 0) {
    std::printf(
        "  warning: the machine itself stalled the loop: %ld preemptions of the force thread, "
        "%.3f s of hypervisor steal time; lateness may come from the host, not hapvox\n",
        r.timing.force_involuntary_switches, r.timing.machine_steal_s);
  }
  if (!broken.empty()) {
    std::string why = "timing budget broken: " + broken.front();
    for (std::size_t i = 1; i < broken.size(); ++i) why += "; " + broken[i];
    throw TimingBudgetBroken(why);
  }
  std::printf("timing budget met\n");
}

}  // namespace

CLI::App* add_replay_subcommand(CLI::App& app, ReplayFlags* flags) {
  CLI::App* cmd = app.add_subcommand(
      "replay",
      "Replay a probe trace against a volume on a simulated 1 kHz clock and record "
      "the force the tool felt in an HDF5 session");
  add_replay_flags(cmd, flags);
  cmd->add_option("--output,-o", flags->output, "Session file to write (.h5)")->required();
  cmd->add_flag("--realtime", flags->realtime,
                "Pace the force loop by the wall clock on its own thread (relaxation on a "
                "second thread) instead of the simulated lockstep clock");
  cmd->add_option("--sculpt-out", flags->sculpt_out,
                  "Write the sculpted volume as PREFIX.vdb and PREFIX.nrrd");
  return cmd;
}

void add_replay_command(CLI::App& app) {
  auto flags = std::make_shared<ReplayFlags>();
  CLI::App* cmd = add_replay_subcommand(app, flags.get());
  cmd->callback([flags] { run_replay(*flags, command_line()); });
}

void add_check_timing_command(CLI::App& app) {
  auto flags = std::make_shared<ReplayFlags>();
  auto budget = std::make_shared<TimingBudget>();
  CLI::App* cmd = app.add_subcommand(
      "check-timing",
      "Replay a trace in realtime and exit 3, saying why, if the force loop broke a timing "
      "budget (for CI; 2 is bad input)");
  add_replay_flags(cmd, flags.get());
  cmd->add_option("--output,-o", flags->output, "Session file to write (.h5)")
      ->default_str("check_timing.h5")
      ->capture_default_str();
  flags->output = "check_timing.h5";
  cmd->add_option("--max-p99-lateness-us", budget->max_p99_lateness_us,
                  "Budget: p99 of tick start lateness, us")
      ->capture_default_str();
  cmd->add_option("--max-miss-rate", budget->max_miss_rate,
                  "Budget: fraction of ticks that end after the next deadline")
      ->capture_default_str();
  cmd->add_option("--min-rate-ratio", budget->min_rate_ratio,
                  "Budget: achieved rate / target rate at least this")
      ->capture_default_str();
  CLI::Option* per_min =
      cmd->add_option("--max-watchdog-per-min", budget->max_watchdog_per_min,
                      "Budget: watchdog trips a minute (ticks that ended over --watchdog-ms "
                      "late)")
          ->capture_default_str();
  cmd->add_option("--max-watchdog-rate", budget->max_watchdog_rate,
                  "Budget: fraction of ticks that tripped the watchdog, instead of a minute's")
      ->excludes(per_min);
  cmd->callback([flags, budget] { run_check_timing(*flags, *budget, command_line()); });
}

}  // namespace hapvox::cli
