#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <sstream>

#include "engine/errors.h"
#include "haptics/trace_h3d.h"
#include "tools/replay_command.h"

namespace hapvox::cli {
namespace {

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

void write_trace_attributes(haptics::SessionWriter& session, const ReplayFlags& f,
                            const haptics::TraceColumns& columns) {
  session.set_attribute("trace_file", f.trace_path);
  session.set_attribute("trace_columns", columns.time + "," + f.trace.pos_cols);
  session.set_attribute("trace_units", f.trace.time_unit + "," + f.trace.pos_unit);
  // An H3D DeviceLog names its own fields and units: the column flags did not apply.
  if (haptics::is_h3d_device_log(f.trace_path)) {
    session.set_attribute("trace_format", std::string("h3d-devicelog"));
  }
}

void write_volume_attributes(haptics::SessionWriter& session, const ReplayFlags& f,
                             const engine::IntensityMapping& mapping,
                             const engine::DensityField& field) {
  session.set_attribute("volume", f.volume);
  session.set_attribute("volume_mapping", mapping_text(mapping));
  session.set_attribute("volume_dims", field.dims().cast<double>().eval());
  session.set_attribute("voxel_size_mm", field.voxel_size_mm());
  session.set_attribute("volume_origin_mm", field.origin_mm());
  // The index axes' world (LPS) directions, as columns: the volume's orientation.
  std::ostringstream direction;
  direction << field.direction().format(
      Eigen::IOFormat(Eigen::FullPrecision, Eigen::DontAlignCols, ",", ";"));
  session.set_attribute("volume_direction", direction.str());
}

}  // namespace

void print_stats_line(const char* label, const haptics::DurationStats& d) {
  std::printf("  %-16s p50 %.1f us, p99 %.1f us, p99.9 %.1f us, max %.1f us (%zu)\n", label,
              d.p50_us, d.p99_us, d.p999_us, d.max_us, d.count);
}

std::string run_source(const ReplayFlags& f) {
  if (f.front_end != nullptr) return f.front_end->name;
  return f.device.empty() ? f.trace_path : f.device;
}

void refuse_empty_run(const ReplayFlags& f, const haptics::ReplaySummary& s,
                      const haptics::BridgeDevice* bridged) {
  if (s.ticks > 0) return;
  std::string refused;
  if (bridged != nullptr) {
    const haptics::BridgeCounters& c = bridged->counters();
    if (c.foreign + c.unauthenticated + c.out_of_window > 0) {
      refused = " (the bridge refused " + std::to_string(c.foreign) + " datagrams from other " +
                "senders, " + std::to_string(c.unauthenticated) + " unauthenticated, " +
                std::to_string(c.out_of_window) + " out of the sequence window)";
    }
  }
  throw InputError(run_source(f), f.device.empty() && f.front_end == nullptr
                                      ? "no tick ran: nothing written to " + f.output
                                      : "no position arrived before the run ended" + refused +
                                            ": no tick ran, nothing written to " + f.output);
}

void check_loop_flags(const ReplayFlags& f) {
  // The API sets these in code, past the command line's parser: the same ranges, the same
  // words.
  check_option_value("--max-force-n", f.limits.max_force_n);
  check_option_value("--ramp-in-s", f.limits.ramp_in_s);
  if (f.realtime && f.trace.rate_hz > 10e3) {
    throw InputError("--rate-hz", "a realtime loop runs at most 10000 Hz");
  }
  check_option_value("--watchdog-ms", f.watchdog_ms);
  if (f.watchdog_periods != 0.0) check_option_value("--watchdog-periods", f.watchdog_periods);
  check_option_value("--cpu", f.cpu);
}

haptics::RealtimeOptions realtime_options(const ReplayFlags& f) {
  haptics::RealtimeOptions realtime_options;
  realtime_options.scheduler.lock_memory = !f.no_mlock;
  realtime_options.scheduler.realtime_policy = !f.no_rt_priority;
  realtime_options.scheduler.pin_cpu = !f.no_pin;
  realtime_options.scheduler.cpu = f.cpu;
  realtime_options.watchdog_ms = f.watchdog_ms;
  realtime_options.watchdog_periods = f.watchdog_periods;
  return realtime_options;
}

haptics::ProgressFn progress_bar(const ReplayFlags& f, const haptics::Device& device) {
  const bool show_progress = !f.quiet && isatty(STDERR_FILENO) && device.tick_count() >= 2000 &&
                             device.tick_count() != haptics::Device::kUnbounded;
  return show_progress ? haptics::ProgressFn(print_progress) : haptics::ProgressFn();
}

void write_run_attributes(haptics::SessionWriter& session, const ReplayFlags& f,
                          const std::string& command_line, const haptics::TraceColumns& columns,
                          const engine::IntensityMapping& mapping,
                          const engine::DensityField& field, const haptics::Device& device,
                          const haptics::ResampledTrace* trace) {
  const haptics::DeviceTransform& transform = device.transform();
  session.set_attribute("command_line", command_line);
  if (trace == nullptr) {
    session.set_attribute("device", f.front_end != nullptr ? f.front_end->name : f.device);
  } else {
    write_trace_attributes(session, f, columns);
  }
  write_volume_attributes(session, f, mapping, field);
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
}

void write_summary_attributes(haptics::SessionWriter& session, const ReplayFlags& f,
                              const haptics::ReplaySummary& s,
                              const haptics::TimingSummary& timing) {
  session.set_attribute("summary_ticks", static_cast<std::int64_t>(s.ticks));
  session.set_attribute("summary_contact_time_s", s.contact_time_s);
  session.set_attribute("summary_peak_force_n", s.peak_force_n);
  session.set_attribute("summary_clamped_ticks", static_cast<std::int64_t>(s.clamped_ticks));
  session.set_attribute("summary_nonfinite_forces", static_cast<std::int64_t>(s.nonfinite_forces));
  session.set_attribute("summary_motion_faults", static_cast<std::int64_t>(s.motion_faults));
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
    session.set_attribute("summary_rows_dropped", static_cast<std::int64_t>(timing.rows_dropped));
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
    session.set_attribute("watchdog_ms", timing.watchdog_ms);
    session.set_attribute("watchdog_periods", timing.watchdog_ms * timing.rate_hz / 1000.0);
  }
}

void print_run_report(const ReplayFlags& f, const haptics::ReplaySummary& s,
                      const haptics::TimingSummary& timing, const haptics::Device& device,
                      const std::string& compute_note) {
  std::printf("  ticks            %zu at %.0f Hz (%.3f s, %s)\n", s.ticks, device.rate_hz(),
              s.duration_s, f.realtime ? "realtime" : "simulated, lockstep");
  std::printf("  tool position    %s .. %s mm (volume space)\n",
              vec_text(s.first_tool_position_mm).c_str(),
              vec_text(s.last_tool_position_mm).c_str());
  std::printf("  contact          %.3f s in %zu ticks, %llu contact onsets\n", s.contact_time_s,
              s.contact_ticks, static_cast<unsigned long long>(s.contact_onsets));
  std::printf("  peak force       %.4f N (clamped on %zu ticks at %.2f N)\n", s.peak_force_n,
              s.clamped_ticks, f.limits.max_force_n);
  std::printf("  compute per tick p50 %.2f us, p99 %.2f us, max %.2f us %s\n", s.compute_p50_us,
              s.compute_p99_us, s.compute_max_us, compute_note.c_str());
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
    if (timing.rows_dropped > 0) {
      std::printf("  session rows     %llu dropped: the session writer fell 8 s behind\n",
                  static_cast<unsigned long long>(timing.rows_dropped));
    }
    std::printf("  scheduler        timer slack %s; memory lock %s; policy %s; affinity %s\n",
                timing.scheduler.timer_slack.c_str(), timing.scheduler.memory_lock.c_str(),
                timing.scheduler.policy.c_str(), timing.scheduler.affinity.c_str());
  }
}

void print_run_footer(const ReplayFlags& f, const haptics::ReplaySummary& s) {
  if (f.realtime && stop_request()->load()) {
    std::printf("  stopped          by Ctrl-C or SIGTERM after %zu ticks (all in the session)\n",
                s.ticks);
  }
  if (s.trace_gaps > 0) {
    std::printf("  trace gaps       %d (tool held for %.3f s)\n", s.trace_gaps, s.trace_held_s);
  }
  if (s.nonfinite_forces > 0) {
    std::printf("  non-finite forces %zu, replaced by the last safe force, ramped out and in\n",
                s.nonfinite_forces);
  }
  if (s.motion_faults > 0) {
    std::printf(
        "  motion faults    %zu device samples moved faster than %.0f mm/s or beyond %.0f mm: "
        "not used, the force ramped out and in\n",
        s.motion_faults, f.limits.max_speed_mm_s, f.limits.max_reach_mm);
  }
}

RenderSetup check_render_flags(const ReplayFlags& f, const engine::DensityField& field) {
  if (!(f.render_fps > 0.0 && f.render_fps <= 240.0)) {
    throw InputError("--render-fps", "must lie in (0, 240]");
  }
  if (f.render_every_ticks < 1) throw InputError("--render-every-ticks", "must be at least 1");
  return resolve_render_flags(f.render, f.volume, field, "render-");
}

std::unique_ptr<FrameRecorder> make_replay_recorder(const ReplayFlags& f,
                                                    const engine::DensityField& field,
                                                    double tool_radius_mm) {
  if (f.render_dir.empty()) return nullptr;
  const RenderSetup setup = check_render_flags(f, field);
  return std::make_unique<FrameRecorder>(field, setup, f.render_dir, tool_radius_mm, f.realtime);
}

void write_render_attributes(haptics::SessionWriter& session, const ReplayFlags& f,
                             const FrameRecorder& recorder, const haptics::TimingSummary& timing) {
  session.set_attribute("render_dir", f.render_dir);
  session.set_attribute("summary_render_frames", static_cast<std::int64_t>(recorder.frames()));
  session.set_attribute("render_shadows",
                        static_cast<std::int64_t>(recorder.setup().settings.shadows.enabled));
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

void print_render_line(const ReplayFlags& f, const FrameRecorder& recorder,
                       const haptics::TimingSummary& timing) {
  const char* shadows = recorder.setup().settings.shadows.enabled ? ", shadows" : "";
  if (f.realtime) {
    std::printf(
        "  render thread    %d frames to %s, %.1f fps (target %.0f), frame p50 %.1f ms, "
        "p99 %.1f ms, max %.1f ms%s\n",
        recorder.frames(), f.render_dir.c_str(), timing.render_fps, f.render_fps,
        1e-3 * timing.render_frame.p50_us, 1e-3 * timing.render_frame.p99_us,
        1e-3 * timing.render_frame.max_us, shadows);
  } else {
    std::printf("  render           %d frames to %s, every %zu ticks, %.1f ms a frame%s\n",
                recorder.frames(), f.render_dir.c_str(), f.render_every_ticks,
                recorder.frame_ms_total() / std::max(1, recorder.frames()), shadows);
  }
}

}  // namespace hapvox::cli
