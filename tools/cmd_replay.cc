// hapvox replay TRACE --volume FILE|GENERATOR -o SESSION.h5

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>

#include "engine/errors.h"
#include "haptics/realtime.h"
#include "tools/cli.h"

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
  std::string sculpt_out;
};

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

void run_replay(const ReplayFlags& f, const std::string& command_line) {
  // Check everything the user gave before reading big files or creating output.
  engine::validate_material(f.force.options.material, "--youngs-modulus-pa", "--poisson");
  const double diameter = f.force.options.tool.diameter_mm;
  if (!std::isfinite(diameter) || diameter <= 0.0) {
    throw InputError("--tool-diameter-mm", "must be positive");
  }
  const double reference = f.force.options.reference_length_mm;
  if (!std::isfinite(reference) || reference < 0.0) {
    throw InputError("--reference-length-mm", "must be positive, or 0 for the tool radius");
  }
  const haptics::TraceColumns columns = f.trace.columns();
  const engine::IntensityMapping mapping = f.mapping.resolve();
  if (!std::isfinite(f.limits.max_force_n) || f.limits.max_force_n <= 0.0) {
    throw InputError("--max-force-n", "must be positive");
  }
  if (!std::isfinite(f.limits.ramp_in_s) || f.limits.ramp_in_s < 0.0) {
    throw InputError("--ramp-in-s", "must be zero or positive");
  }
  check_output_path(f.output, "--output");
  if (!f.sculpt_out.empty()) {
    if (!f.plastic) throw InputError("--sculpt-out", "needs --plastic");
    check_output_path(f.sculpt_out + ".vdb", "--sculpt-out");
  }
  if (!(f.relax_tolerance >= 0.0 && f.relax_tolerance <= 10.0)) {
    throw InputError("--relax-tolerance", "must lie in [0, 10]");
  }
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
  engine::ToolForceOptions force_options = f.force.options;
  force_options.plastic.enabled = f.plastic;

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
  session.set_attribute("youngs_modulus_pa", model.options().material.youngs_modulus_pa);
  session.set_attribute("poisson_ratio", model.options().material.poisson_ratio);
  session.set_attribute("lame_lambda_pa", model.lame().lambda_pa);
  session.set_attribute("lame_mu_pa", model.lame().mu_pa);
  session.set_attribute("tool_diameter_mm", model.options().tool.diameter_mm);
  session.set_attribute("reference_length_mm", model.reference_length_mm());
  session.set_attribute("slip_ratio", model.options().slip_ratio);
  session.set_attribute("surface_samples", std::int64_t{model.surface_sample_count()});
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
    session.set_attribute("normal_density_units", std::int64_t{engine::kNormalDensityUnits});
  }
  std::unique_ptr<engine::MassGrid> mass;
  haptics::SurfaceChangeChannel channel;
  haptics::SculptContext sculpt;
  haptics::SculptSummary sculpted;
  haptics::RealtimeSculpt realtime_sculpt;
  haptics::TimingSummary timing;
  if (f.plastic) {
    engine::RelaxOptions relax_options;
    relax_options.tolerance = f.relax_tolerance;
    mass = std::make_unique<engine::MassGrid>(field, relax_options);
    sculpt.mass = mass.get();
    sculpt.mirror = &field;
    sculpt.channel = &channel;
    sculpt.relax_voxels_per_tick = f.relax_voxels_per_tick;
    realtime_sculpt.mass = mass.get();
    realtime_sculpt.field = buffers.get();
    realtime_sculpt.channel = &channel;
    realtime_sculpt.relax_voxels_per_slice = f.relax_voxels_per_tick;
  }
  const bool show_progress = !f.quiet && isatty(STDERR_FILENO) && device.tick_count() >= 2000;
  haptics::ReplaySummary s;
  try {
    const haptics::ProgressFn progress =
        show_progress ? haptics::ProgressFn(print_progress) : haptics::ProgressFn();
    if (f.realtime) {
      s = haptics::replay_realtime(model, device, f.limits, &session, progress,
                                   f.plastic ? &realtime_sculpt : nullptr, &sculpted, &timing);
    } else {
      s = haptics::replay_lockstep(model, device, f.limits, &session, progress,
                                   f.plastic ? &sculpt : nullptr, &sculpted);
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
    session.set_attribute("summary_lateness_p50_us", timing.lateness_p50_us);
    session.set_attribute("summary_lateness_p99_us", timing.lateness_p99_us);
    session.set_attribute("summary_lateness_p999_us", timing.lateness_p999_us);
    session.set_attribute("summary_lateness_max_us", timing.lateness_max_us);
    session.set_attribute("summary_missed_deadlines",
                          static_cast<std::int64_t>(timing.missed_deadlines));
    session.set_attribute("summary_achieved_rate_hz", timing.achieved_rate_hz);
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
    std::printf(
        "  lateness         p50 %.1f us, p99 %.1f us, p99.9 %.1f us, max %.1f us; "
        "%zu missed deadlines; %.1f Hz achieved\n",
        timing.lateness_p50_us, timing.lateness_p99_us, timing.lateness_p999_us,
        timing.lateness_max_us, timing.missed_deadlines, timing.achieved_rate_hz);
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
  if (s.trace_gaps > 0) {
    std::printf("  trace gaps       %d (tool held for %.3f s)\n", s.trace_gaps, s.trace_held_s);
  }
  if (s.nonfinite_forces > 0) {
    std::printf("  non-finite forces replaced by zero: %zu\n", s.nonfinite_forces);
  }
}

}  // namespace

void add_replay_command(CLI::App& app) {
  auto flags = std::make_shared<ReplayFlags>();
  CLI::App* cmd = app.add_subcommand(
      "replay",
      "Replay a probe trace against a volume on a simulated 1 kHz clock and record "
      "the force the tool felt in an HDF5 session");
  cmd->add_option("trace", flags->trace_path, "Trace file (.csv or .h5)")->required();
  cmd->add_option("--volume,-v", flags->volume,
                  "Volume file (.nrrd, .nhdr, .vdb) or generator (block, sphere, four-spheres)")
      ->required();
  cmd->add_option("--output,-o", flags->output, "Session file to write (.h5)")->required();
  cmd->add_option("--max-force-n", flags->limits.max_force_n, "Device force limit, N")
      ->capture_default_str();
  cmd->add_option("--ramp-in-s", flags->limits.ramp_in_s, "Force ramp-in time at start, s")
      ->capture_default_str();
  cmd->add_flag("--quiet,-q", flags->quiet, "No progress bar");
  flags->mapping.add_to(*cmd);
  flags->trace.add_to(*cmd);
  flags->transform.add_to(*cmd);
  flags->force.add_to(*cmd);
  cmd->add_flag("--realtime", flags->realtime,
                "Pace the force loop by the wall clock on its own thread (relaxation on a "
                "second thread) instead of the simulated lockstep clock");
  cmd->add_flag("--plastic", flags->plastic,
                "Sculpt: incremental plasticity, deletion and progressive relaxation");
  cmd->add_option("--yield-stress-pa", flags->force.options.plastic.yield_stress_pa,
                  "Yield stress sigma_f, Pa")
      ->capture_default_str();
  cmd->add_option("--elastoplastic-modulus-pa",
                  flags->force.options.plastic.elastoplastic_modulus_pa,
                  "Elasto-plastic slope E_ep in [0, E), Pa (> 0: linear hardening)")
      ->capture_default_str();
  cmd->add_option("--relax-voxels-per-tick", flags->relax_voxels_per_tick,
                  "Relaxation budget per 1 kHz tick (lockstep) or per slice of the relaxation "
                  "thread (realtime)")
      ->capture_default_str();
  cmd->add_option("--relax-tolerance", flags->relax_tolerance,
                  "Settled when no voxel exceeds normal density by more than this fraction")
      ->capture_default_str();
  cmd->add_option("--sculpt-out", flags->sculpt_out,
                  "Write the sculpted volume as PREFIX.vdb and PREFIX.nrrd");
  cmd->callback([flags] { run_replay(*flags, command_line()); });
}

}  // namespace hapvox::cli
