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
#include "haptics/voxel_model.h"
#include "tools/cli.h"
#include "tools/render_output.h"

namespace hapvox::cli {
namespace {

struct ReplayFlags {
  std::string trace_path;
  std::string volume;
  std::string output;
  bool quiet = false;
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
  double watchdog_periods = 1.0;
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

void print_stats_line(const char* label, const haptics::DurationStats& d) {
  std::printf("  %-16s p50 %.1f us, p99 %.1f us, p99.9 %.1f us, max %.1f us (%zu)\n", label,
              d.p50_us, d.p99_us, d.p999_us, d.max_us, d.count);
}

std::string vec_text(const Eigen::Vector3d& v) {
  std::ostringstream out;
  out << v.x() << "," << v.y() << "," << v.z();
  return out.str();
}

std::string mapping_text(const engine::IntensityMapping& m) {
  std::ostringstream out;
  switch (m.kind) {
    case engine::IntensityMapping::Kind::kAuto:
      out << "auto (Otsu threshold)";
      break;
    case engine::IntensityMapping::Kind::kThreshold:
      out << "threshold " << m.low;
      break;
    case engine::IntensityMapping::Kind::kWindow:
      out << "window " << m.low << "," << m.high;
      break;
  }
  return out.str();
}

void print_progress(std::size_t done, std::size_t total) {
  const int width = 40;
  const int filled = static_cast<int>(width * done / std::max<std::size_t>(total, 1));
  std::fprintf(stderr, "\r[%.*s%*s] %3zu%% %zu/%zu ticks", filled,
               "########################################", width - filled, "",
               100 * done / std::max<std::size_t>(total, 1), done, total);
  if (done == total) std::fprintf(stderr, "\n");
}

ReplayResult run_replay(const ReplayFlags& f, const std::string& command_line) {
  // Check everything the user gave before reading big files or creating output.
  engine::validate_material(f.force.options.material, "--youngs-modulus-pa", "--poisson");
  const double diameter = f.force.options.tool.diameter_mm;
  if (!std::isfinite(diameter) || diameter <= 0.0) {
    throw InputError("--tool-diameter-mm", "must be positive");
  }
  const haptics::TraceColumns columns = f.trace.columns();
  const engine::IntensityMapping mapping = f.mapping.resolve();
  if (!std::isfinite(f.limits.max_force_n) || f.limits.max_force_n <= 0.0) {
    throw InputError("--max-force-n", "must be positive");
  }
  if (!std::isfinite(f.limits.ramp_in_s) || f.limits.ramp_in_s < 0.0) {
    throw InputError("--ramp-in-s", "must be zero or positive");
  }
  if (f.realtime && f.trace.rate_hz > 10e3) {
    throw InputError("--rate-hz", "a realtime loop runs at most 10000 Hz");
  }
  if (!(f.watchdog_periods > 0.0) || !std::isfinite(f.watchdog_periods)) {
    throw InputError("--watchdog-periods", "must be positive");
  }
  if (f.cpu < -1 || f.cpu >= 1024)
    throw InputError("--cpu", "must be a CPU number (or -1 for the last)");
  check_output_path(f.output, "--output");
  if (!f.sculpt_out.empty()) {
    if (!f.plastic) throw InputError("--sculpt-out", "needs --plastic");
    check_output_path(f.sculpt_out + ".vdb", "--sculpt-out");
  }
  std::vector<InputPath> inputs = volume_inputs(f.volume);
  inputs.push_back({f.trace_path, "trace"});
  if (!f.render_dir.empty()) {
    for (const InputPath& input : transfer_inputs(f.render.transfer)) inputs.push_back(input);
  }
  const std::string& prefix = f.sculpt_out;  // writes PREFIX.vdb and PREFIX.nrrd
  check_outputs_spare_inputs({{f.output, "--output", ""},
                              {prefix.empty() ? "" : prefix + ".vdb", "--sculpt-out", ""},
                              {prefix.empty() ? "" : prefix + ".nrrd", "--sculpt-out", ""},
                              {f.render_dir, "--render-dir", kFrameFileNames}},
                             inputs);
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

  const haptics::Trace trace = haptics::read_trace(f.trace_path, columns);
  engine::DensityField field = engine::load_volume(f.volume, mapping);
  // Realtime sculpting: the force thread reads one of two buffers the relaxation updates.
  std::unique_ptr<haptics::DoubleBufferedField> buffers;
  if (f.realtime && f.plastic) buffers = std::make_unique<haptics::DoubleBufferedField>(field);
  const engine::ToolForceModel model(buffers ? buffers->buffer(0) : field, force_options);
  const haptics::DeviceTransform transform = f.transform.resolve(trace, field);
  haptics::ResampleOptions resample_options;
  resample_options.rate_hz = f.trace.rate_hz;
  resample_options.max_gap_s = f.trace.max_gap_s;
  const haptics::TraceDevice device(haptics::resample(trace, resample_options), transform);
  const std::vector<std::string> warnings = replay_warnings(f.trace_path, model, device);

  // The render output before the session: a machine without EGL fails before any file.
  std::unique_ptr<FrameRecorder> recorder;
  if (!f.render_dir.empty()) {
    if (!(f.render_fps > 0.0 && f.render_fps <= 240.0)) {
      throw InputError("--render-fps", "must lie in (0, 240]");
    }
    if (f.render_every_ticks < 1) throw InputError("--render-every-ticks", "must be at least 1");
    const RenderSetup setup = resolve_render_flags(f.render, f.volume, field, "render-");
    recorder = std::make_unique<FrameRecorder>(field, setup, f.render_dir,
                                               0.5 * model.options().tool.diameter_mm, f.realtime);
  }
  haptics::SessionWriter session(f.output);
  session.set_attribute("command_line", command_line);
  session.set_attribute("trace_file", f.trace_path);
  session.set_attribute("trace_columns", columns.time + "," + f.trace.pos_cols);
  session.set_attribute("trace_units", f.trace.time_unit + "," + f.trace.pos_unit);
  session.set_attribute("volume", f.volume);
  session.set_attribute("volume_mapping", mapping_text(mapping));
  session.set_attribute("volume_dims", field.dims().cast<double>().eval());
  session.set_attribute("voxel_size_mm", field.voxel_size_mm());
  session.set_attribute("volume_origin_mm", field.origin_mm());
  session.set_attribute("loop_rate_hz", device.rate_hz());
  session.set_attribute("clock", std::string(f.realtime ? "realtime" : "lockstep"));
  session.set_attribute("max_gap_s", f.trace.max_gap_s);
  session.set_attribute("max_force_n", f.limits.max_force_n);
  session.set_attribute("ramp_in_s", f.limits.ramp_in_s);
  session.set_attribute("transform_scale", transform.scale);
  session.set_attribute("transform_offset_mm", transform.offset_mm);
  std::ostringstream rotation;
  rotation << transform.rotation.format(Eigen::IOFormat(Eigen::FullPrecision, 0, ",", ";"));
  session.set_attribute("transform_rotation", rotation.str());
  for (const auto& [name, version] : haptics::library_versions()) {
    session.set_attribute("version_" + name, version);
  }

  session.set_attribute("plastic", std::int64_t{f.plastic ? 1 : 0});
  if (f.plastic) {
    session.set_attribute("yield_stress_pa", force_options.plastic.yield_stress_pa);
    session.set_attribute("elastoplastic_modulus_pa",
                          force_options.plastic.elastoplastic_modulus_pa);
    session.set_attribute("relax_voxels_per_tick",
                          static_cast<std::int64_t>(f.relax_voxels_per_tick));
    session.set_attribute("relax_tolerance", f.relax_tolerance);
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
        f.realtime
            ? std::make_unique<haptics::RelaxationStage>(*mass, channel, *buffers, budget)
            : std::make_unique<haptics::RelaxationStage>(*mass, channel, field, force, budget);
  }
  force.write_attributes(session);
  const bool show_progress = !f.quiet && isatty(STDERR_FILENO) && device.tick_count() >= 2000;
  haptics::ReplaySummary s;
  try {
    const haptics::ProgressFn progress =
        show_progress ? haptics::ProgressFn(print_progress) : haptics::ProgressFn();
    if (f.realtime) {
      haptics::RealtimeOptions realtime_options;
      realtime_options.scheduler.lock_memory = !f.no_mlock;
      realtime_options.scheduler.realtime_policy = !f.no_rt_priority;
      realtime_options.scheduler.pin_cpu = !f.no_pin;
      realtime_options.scheduler.cpu = f.cpu;
      realtime_options.watchdog_periods = f.watchdog_periods;
      if (recorder) {
        realtime_options.render_loop = recorder->realtime_loop(f.render_fps);
        realtime_options.scheduler.lock_future_memory = false;
      }
      s = haptics::replay_realtime(force, relaxation.get(), device, f.limits, &session, progress,
                                   &sculpted, &timing, realtime_options);
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
  } catch (...) {
    session.abandon();
    throw;
  }
  session.set_attribute("summary_ticks", static_cast<std::int64_t>(s.ticks));
  session.set_attribute("summary_contact_time_s", s.contact_time_s);
  session.set_attribute("summary_peak_force_n", s.peak_force_n);
  session.set_attribute("summary_clamped_ticks", static_cast<std::int64_t>(s.clamped_ticks));
  session.set_attribute("summary_nonfinite_forces", static_cast<std::int64_t>(s.nonfinite_forces));
  session.set_attribute("summary_trace_gaps", std::int64_t{s.trace_gaps});
  session.set_attribute("summary_compute_p50_us", s.compute_p50_us);
  session.set_attribute("summary_compute_p99_us", s.compute_p99_us);
  if (f.realtime) {
    session.set_attribute("summary_lateness_p50_us", timing.lateness.p50_us);
    session.set_attribute("summary_lateness_p99_us", timing.lateness.p99_us);
    session.set_attribute("summary_lateness_p999_us", timing.lateness.p999_us);
    session.set_attribute("summary_lateness_max_us", timing.lateness.max_us);
    session.set_attribute("summary_missed_deadlines",
                          static_cast<std::int64_t>(timing.missed_deadlines));
    session.set_attribute("summary_watchdog_trips",
                          static_cast<std::int64_t>(timing.watchdog_trips));
    session.set_attribute("summary_watchdog_ramped_ticks",
                          static_cast<std::int64_t>(timing.watchdog_ramped_ticks));
    session.set_attribute("summary_stalled_ticks", static_cast<std::int64_t>(timing.stalled_ticks));
    session.set_attribute("summary_achieved_rate_hz", timing.achieved_rate_hz);
    session.set_attribute("summary_wall_time_s", timing.wall_time_s);
    session.set_attribute("summary_force_cpu_s", timing.force_cpu_s);
    session.set_attribute("summary_force_involuntary_switches",
                          static_cast<std::int64_t>(timing.force_involuntary_switches));
    session.set_attribute("summary_machine_steal_s", timing.machine_steal_s);
    session.set_attribute("scheduler_timer_slack", timing.scheduler.timer_slack);
    session.set_attribute("scheduler_memory_lock", timing.scheduler.memory_lock);
    session.set_attribute("scheduler_policy", timing.scheduler.policy);
    session.set_attribute("scheduler_affinity", timing.scheduler.affinity);
    session.set_attribute("watchdog_periods", f.watchdog_periods);
    if (f.plastic) {
      session.set_attribute("summary_relax_slice_p50_us", timing.relax_slice.p50_us);
      session.set_attribute("summary_relax_slice_p99_us", timing.relax_slice.p99_us);
      session.set_attribute("summary_relax_slice_max_us", timing.relax_slice.max_us);
      session.set_attribute("summary_relax_busy_fraction", timing.relax_busy_fraction);
      session.set_attribute("summary_relax_cpu_s", timing.relax_cpu_s);
      session.write_array("timing/relax_slice_ns", timing.relax_slice_ns, "ns");
      session.write_array("timing/relax_slice_start_ns", timing.relax_slice_start_ns, "ns");
    }
  }
  if (recorder) {
    session.set_attribute("render_dir", f.render_dir);
    session.set_attribute("summary_render_frames", static_cast<std::int64_t>(recorder->frames()));
    if (f.realtime) {
      session.set_attribute("render_target_fps", f.render_fps);
      session.set_attribute("summary_render_fps", timing.render_fps);
      session.set_attribute("summary_render_frame_p50_us", timing.render_frame.p50_us);
      session.set_attribute("summary_render_frame_p99_us", timing.render_frame.p99_us);
      session.set_attribute("summary_render_frame_max_us", timing.render_frame.max_us);
      session.write_array("render/frame_start_ns", timing.render.frame_start_ns, "ns");
      session.write_array("render/frame_ns", timing.render.frame_ns, "ns");
      session.write_array("render/frame_tick", timing.render.frame_tick, "tick");
    } else {
      session.set_attribute("render_every_ticks", static_cast<std::int64_t>(f.render_every_ticks));
    }
  }
  if (f.plastic) {
    session.set_attribute("summary_plastic_events",
                          static_cast<std::int64_t>(sculpted.plastic_events));
    session.set_attribute("summary_initial_mass_units", sculpted.initial_mass_units);
    session.set_attribute("summary_final_mass_units", sculpted.final_mass_units);
    session.set_attribute("summary_queue_overflows",
                          static_cast<std::int64_t>(sculpted.queue_overflows));
  }
  session.close();
  if (!f.sculpt_out.empty()) {
    const engine::DensityField sculpted_field = mass->to_density_field();
    engine::write_vdb(sculpted_field, f.sculpt_out + ".vdb");
    engine::write_nrrd(sculpted_field, f.sculpt_out + ".nrrd");
  }

  std::printf("replayed %s on %s -> %s\n", f.trace_path.c_str(), f.volume.c_str(),
              f.output.c_str());
  std::printf("  ticks            %zu at %.0f Hz (%.3f s, %s)\n", s.ticks, device.rate_hz(),
              s.duration_s, f.realtime ? "realtime" : "simulated, lockstep");
  std::printf("  tool position    %s .. %s mm (volume space)\n",
              vec_text(device.tool_position_mm(0)).c_str(),
              vec_text(device.tool_position_mm(s.ticks - 1)).c_str());
  std::printf("  contact          %.3f s in %zu ticks, %llu contact onsets\n", s.contact_time_s,
              s.contact_ticks, static_cast<unsigned long long>(s.contact_onsets));
  std::printf("  peak force       %.4f N (clamped on %zu ticks at %.2f N)\n", s.peak_force_n,
              s.clamped_ticks, f.limits.max_force_n);
  std::printf("  compute per tick p50 %.2f us, p99 %.2f us, max %.2f us (%d surface samples)\n",
              s.compute_p50_us, s.compute_p99_us, s.compute_max_us, model.surface_sample_count());
  if (f.realtime) {
    print_stats_line("lateness", timing.lateness);
    std::printf(
        "  deadlines        %zu missed (%.3f%%), %zu watchdog trips (%llu ticks ramped down), "
        "%.1f Hz achieved of %.0f\n",
        timing.missed_deadlines,
        100.0 * timing.missed_deadlines / std::max<std::size_t>(1, s.ticks), timing.watchdog_trips,
        static_cast<unsigned long long>(timing.watchdog_ramped_ticks), timing.achieved_rate_hz,
        timing.rate_hz);
    std::printf(
        "  force thread     %.3f s CPU in %.3f s wall, preempted %ld times, %zu ticks started "
        ">1 period late; machine steal %.3f s\n",
        timing.force_cpu_s, timing.wall_time_s, timing.force_involuntary_switches,
        timing.stalled_ticks, timing.machine_steal_s);
    std::printf("  scheduler        timer slack %s; memory lock %s; policy %s; affinity %s\n",
                timing.scheduler.timer_slack.c_str(), timing.scheduler.memory_lock.c_str(),
                timing.scheduler.policy.c_str(), timing.scheduler.affinity.c_str());
    if (f.plastic) {
      print_stats_line("relax slices", timing.relax_slice);
      std::printf("  relax thread     busy %.1f%% of the wall time, %.3f s CPU\n",
                  100.0 * timing.relax_busy_fraction, timing.relax_cpu_s);
    }
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
    std::printf(
        "  mass             %lld -> %lld units (%s)\n",
        static_cast<long long>(sculpted.initial_mass_units),
        static_cast<long long>(sculpted.final_mass_units),
        sculpted.initial_mass_units == sculpted.final_mass_units ? "conserved exactly" : "CHANGED");
    if (!f.sculpt_out.empty()) {
      std::printf("  sculpted volume  %s.vdb, %s.nrrd\n", f.sculpt_out.c_str(),
                  f.sculpt_out.c_str());
    }
  }
  if (recorder) {
    if (f.realtime) {
      std::printf(
          "  render thread    %d frames to %s, %.1f fps (target %.0f), frame p50 %.1f ms, "
          "p99 %.1f ms, max %.1f ms\n",
          recorder->frames(), f.render_dir.c_str(), timing.render_fps, f.render_fps,
          1e-3 * timing.render_frame.p50_us, 1e-3 * timing.render_frame.p99_us,
          1e-3 * timing.render_frame.max_us);
    } else {
      std::printf("  render           %d frames to %s, every %zu ticks, %.1f ms a frame\n",
                  recorder->frames(), f.render_dir.c_str(), f.render_every_ticks,
                  recorder->frame_ms_total() / std::max(1, recorder->frames()));
    }
  }
  if (s.trace_gaps > 0) {
    std::printf("  trace gaps       %d (tool held for %.3f s)\n", s.trace_gaps, s.trace_held_s);
  }
  if (s.nonfinite_forces > 0) {
    std::printf("  non-finite forces replaced by zero: %zu\n", s.nonfinite_forces);
  }
  print_warnings(warnings);
  return ReplayResult{s, timing, sculpted};
}

void add_replay_flags(CLI::App* cmd, ReplayFlags* flags) {
  cmd->add_option("trace", flags->trace_path, "Trace file (.csv or .h5)")->required();
  cmd->add_option("--volume,-v", flags->volume,
                  "Volume file (.nrrd, .nhdr, .vdb) or generator (block, sphere, four-spheres)")
      ->required();
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
  flags->render.size = "256";  // frames beside a force loop: small by default
  flags->render.add_to(*cmd, "render-");
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
  cmd->add_option("--watchdog-periods", flags->watchdog_periods,
                  "Realtime: a tick ending more than this many periods after its deadline "
                  "trips the watchdog: the force ramps down to zero and back over --ramp-in-s")
      ->capture_default_str();
}

struct TimingBudget {
  double max_p99_lateness_us = 250.0;
  double max_miss_rate = 0.005;
  double min_rate_ratio = 0.98;
  double max_watchdog_rate = 0.005;
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
  if (!(budget.max_watchdog_rate >= 0.0 && budget.max_watchdog_rate <= 1.0)) {
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
  check(watchdog_rate <= budget.max_watchdog_rate,
        "watchdog trips %.4f%% of ticks (budget <= %.4f%%)", 100.0 * watchdog_rate,
        100.0 * budget.max_watchdog_rate);
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

void add_replay_command(CLI::App& app) {
  auto flags = std::make_shared<ReplayFlags>();
  CLI::App* cmd = app.add_subcommand(
      "replay",
      "Replay a probe trace against a volume on a simulated 1 kHz clock and record "
      "the force the tool felt in an HDF5 session");
  add_replay_flags(cmd, flags.get());
  cmd->add_option("--output,-o", flags->output, "Session file to write (.h5)")->required();
  cmd->add_flag("--realtime", flags->realtime,
                "Pace the force loop by the wall clock on its own thread (relaxation on a "
                "second thread) instead of the simulated lockstep clock");
  cmd->add_option("--sculpt-out", flags->sculpt_out,
                  "Write the sculpted volume as PREFIX.vdb and PREFIX.nrrd");
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
  cmd->add_option("--max-watchdog-rate", budget->max_watchdog_rate,
                  "Budget: fraction of ticks that tripped the watchdog")
      ->capture_default_str();
  cmd->callback([flags, budget] { run_check_timing(*flags, *budget, command_line()); });
}

}  // namespace hapvox::cli
