// hapvox replay TRACE --volume V --model fem --materials M.toml [--labels L | --seed X,Y,Z]
// -o S.h5: the proxy-FEM model (haptics/fem_model.h) through the same loops, session and
// report as the voxel model; the session also holds the mesh and the node displacements of
// every FEM step, and S.xdmf beside it opens them in ParaView as a time series.
// `hapvox sculpt` runs it too (ReplayFlags::front_end): its window's device moves the tool
// and the FEM is paced in lockstep with the force loop, so the session's trace replays it
// (with --no-tool-refine: the mesh a live session builds is not refined along a path).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include "engine/errors.h"
#include "haptics/fem_model.h"
#include "haptics/mesh_file.h"
#include "haptics/trace_resample.h"
#include "tools/relabel.h"
#include "tools/replay_command.h"

namespace hapvox::cli {

Eigen::AlignedBox3d fem_tool_region(const haptics::TraceDevice& device, double radius_mm) {
  Eigen::AlignedBox3d box;
  for (std::size_t k = 0; k < device.tick_count(); ++k) box.extend(device.tool_position_mm(k));
  box.min().array() -= radius_mm;
  box.max().array() += radius_mm;
  return box;
}

haptics::LockstepRender fem_lockstep_frames(FrameRecorder& recorder, const haptics::FemModel& model,
                                            const haptics::FemBackgroundStage& fem,
                                            std::size_t every_ticks) {
  haptics::LockstepRender render;
  render.every_ticks = every_ticks;
  auto deformed_tick = std::make_shared<std::int64_t>(-1);
  render.frame = [&recorder, &model, &fem, deformed_tick](std::size_t,
                                                          const haptics::RenderToolState& tool) {
    const haptics::FemFrame& latest = fem.frames().back();
    if (latest.tick != *deformed_tick) {  // a FEM step since the last frame
      // The mesh its displacements belong to: the run's first or a remesh's.
      const engine::fem::TetMesh& mesh =
          latest.mesh == 0
              ? model.mesh()
              : fem.remeshes()[static_cast<std::size_t>(latest.mesh - 1)]->model->mesh();
      recorder.deform(mesh, latest.mesh,
                      Eigen::Map<const Eigen::VectorXd>(
                          latest.displacement_mm.data(),
                          static_cast<Eigen::Index>(latest.displacement_mm.size())));
      *deformed_tick = latest.tick;
    }
    recorder.draw(tool);
  };
  return render;
}

ReplayResult run_fem_replay(const ReplayFlags& f, const std::string& command_line) {
  // A live device moves the tool: sculpt's window (the FEM paced in lockstep with the force
  // loop), or the bridge (--device; the FEM on its own thread); no trace.
  const bool windowed = f.front_end != nullptr;
  const bool live = windowed || !f.device.empty();
  // Check everything the user gave before reading big files or creating output.
  if (f.plastic)
    throw InputError("--plastic", "needs --model voxel (the FEM model does not sculpt)");
  if (!f.sculpt_out.empty()) throw InputError("--sculpt-out", "needs --model voxel");
  if (f.fem_mesh.materials.empty()) throw InputError("--materials", "--model fem needs one");
  const haptics::FemOptions options = f.fem_run.resolve(f.force.options.tool.diameter_mm);
  std::vector<Relabel> relabels;
  for (const std::string& text : f.relabels) relabels.push_back(parse_relabel(text));
  const std::optional<engine::proxy::IncisionFile> incision = f.fem_run.read_incision();
  if (incision && !relabels.empty()) {
    throw InputError("--incision",
                     "cannot be combined with --relabel (a relabelled mesh would "
                     "lose the cut)");
  }
  if (live) {
    if (options.interaction == haptics::FemInteraction::kGrab) {
      throw InputError("--interaction",
                       "a live session presses with the FEM model (a grab holds what lies "
                       "within reach of a trace's first position, which a live session has not)");
    }
    if (!relabels.empty())
      throw InputError("--relabel", "needs a trace (its times are trace times)");
    if (incision && incision->at_s) {
      throw InputError(incision->source, "at_s needs a trace: a live session cuts from the start");
    }
  }
  const haptics::TraceColumns columns = f.trace.columns();
  const engine::IntensityMapping mapping = f.mapping.resolve();
  check_loop_flags(f);
  check_output_path(f.output, "--output");
  const std::string xdmf = haptics::xdmf_path_for(f.output);
  std::vector<InputPath> inputs = volume_inputs(f.volume);
  if (!live) inputs.push_back({f.trace_path, "trace"});
  for (const InputPath& input : fem_inputs(f.fem_mesh)) inputs.push_back(input);
  if (incision) inputs.push_back({incision->source, "incision file"});
  if (!f.render_dir.empty()) {
    for (const InputPath& input : transfer_inputs(f.render.transfer)) inputs.push_back(input);
  }
  check_outputs_spare_inputs({{f.output, "--output", ""},
                              {xdmf, "--output", ""},
                              {f.trace_out, "--trace-out", ""},
                              {f.render_dir, "--render-dir", kFrameFileNames}},
                             inputs);

  std::optional<haptics::Trace> trace;
  if (!live) trace = haptics::read_trace(f.trace_path, columns);
  const engine::DensityField field = engine::load_volume(f.volume, mapping);
  // The device: a replayed trace, the window's (sculpt), or the bridge. The bridge is bound
  // last, once the mesh is built (seconds for a big one, or under a sanitizer): a device
  // program waits for the port, and what it sent before the loop ran would be lost.
  std::unique_ptr<haptics::TraceDevice> traced;
  std::unique_ptr<haptics::Device> fronted;
  std::unique_ptr<haptics::BridgeDevice> bridge;
  if (windowed) {
    fronted = f.front_end->make_device(field, options.tool_radius_mm);
  } else if (!live) {
    haptics::ResampleOptions resample_options;
    resample_options.rate_hz = f.trace.rate_hz;
    resample_options.max_gap_s = f.trace.max_gap_s;
    traced = std::make_unique<haptics::TraceDevice>(
        haptics::resample(*trace, resample_options, f.trace_path),
        f.transform.resolve(*trace, field));
    if (traced->tick_count() == 0) throw InputError(f.trace_path, "the trace has no samples");
  }
  // The bridge's loop runs at the trace flags' rate (make_bridge_device).
  const double rate_hz = fronted  ? fronted->rate_hz()
                         : traced ? traced->rate_hz()
                                  : f.trace.rate_hz;
  if (!f.render_dir.empty()) check_render_flags(f, field);  // before the mesh is built
  // The mesh is refined further where a trace's tool goes; a live session's path is not
  // known ahead (its trace replays with --no-tool-refine).
  std::optional<engine::fem::Region> tool_region;
  if (traced && !f.no_tool_refine) tool_region = fem_tool_region(*traced, options.tool_radius_mm);
  const ProxyInputs proxy_inputs = proxy_inputs_from_cli(f.volume, f.fem_mesh, tool_region);
  const std::size_t ticks = traced ? traced->tick_count() : 0;
  std::vector<haptics::LabelChange> changes = label_changes(relabels, proxy_inputs, ticks, rate_hz);
  engine::proxy::ProxyMesh proxy = engine::proxy::build_proxy_mesh(
      proxy_inputs.labels, proxy_inputs.materials, proxy_inputs.mesh);
  if (incision) plan_incision(*incision, live, ticks, rate_hz, proxy, changes);
  const haptics::FemModel model(std::move(proxy), options);
  // The stages (haptics/fem_model.h); the loops see only their seams.
  auto handoff = std::make_unique<haptics::FemHandoff>();
  haptics::FemForceStage force(model, *handoff);
  // The first snapshot is made where the tool starts: the trace's first position, or (live)
  // the window's start, or above the volume for a device yet to be heard from.
  haptics::FemBackgroundStage fem(model, *handoff,
                                  traced     ? traced->tool_position_mm(0)
                                  : windowed ? f.front_end->start_mm
                                             : above_volume_mm(field, options.tool_radius_mm));
  fem.set_label_changes(std::move(changes));
  // Frames show the volume as the proxy mesh deforms it; a grab's capture sphere is not drawn
  // (it would hide what it holds), a press's tool is.
  std::unique_ptr<FrameRecorder> recorder = make_replay_recorder(
      f, field,
      options.interaction == haptics::FemInteraction::kPress ? options.tool_radius_mm : 0.0);
  if (recorder) recorder->use_proxy_mesh();
  // The window, before the session file (a machine without a display fails before any output).
  haptics::RenderLoop window_loop;
  if (windowed)
    window_loop = f.front_end->make_render_loop(field, *fronted, options.tool_radius_mm);
  // The bridge, bound before any file is made (a port in use is one line).
  if (live && !windowed) bridge = make_bridge_device(f, f.transform.resolve_fixed());
  haptics::Device& device = fronted  ? *fronted
                            : bridge ? static_cast<haptics::Device&>(*bridge)
                                     : *traced;
  // The bridge's counts go in the session: ours, or the one behind sculpt's window.
  const haptics::BridgeDevice* bridged = bridge     ? bridge.get()
                                         : windowed ? f.front_end->bridge
                                                    : nullptr;
  // A tick's time: the trace's, or (live) ticks from zero at the loop's rate.
  auto time_s = [&](std::int64_t tick) {
    return traced ? traced->time_s(static_cast<std::size_t>(tick))
                  : static_cast<double>(tick) / device.rate_hz();
  };

  haptics::SessionWriter session(f.output);
  write_run_attributes(session, f, command_line, columns, mapping, field, device,
                       traced ? &traced->trace() : nullptr);
  session.set_attribute("fem_schedule", std::string(windowed     ? "lockstep, paced by the clock"
                                                    : f.realtime ? "own thread"
                                                                 : "lockstep"));
  session.set_attribute("fem_tool_refine", std::int64_t{tool_region ? 1 : 0});
  if (incision) {
    session.set_attribute("incision", incision->source);
    session.set_attribute("incision_width_mm", incision->width_mm);
    session.set_attribute("incision_at_s", incision->at_s.value_or(0.0));
  }
  haptics::TimingSummary timing;
  haptics::ReplaySummary s;
  try {
    const haptics::ProgressFn progress = progress_bar(f, device);
    if (f.realtime) {
      haptics::RealtimeOptions realtime = realtime_options(f);
      if (recorder) {
        realtime.render_loop = recorder->realtime_loop(f.render_fps);
        realtime.scheduler.lock_future_memory = false;  // Mesa maps memory on its threads
      }
      const StopOnSignals stop_on_signals;  // as the voxel model's realtime runs (cmd_replay.cc)
      realtime.stop = stop_request();
      if (windowed) {
        // Paced in lockstep (a FEM step after every fem_every_ticks-th tick, before the
        // next): the session's trace replays it bit for bit.
        realtime.background_in_lockstep = true;
        realtime.render_loop = window_loop;
        realtime.scheduler.lock_future_memory = false;
      }
      s = haptics::replay_realtime(force, &fem, device, f.limits, &session, progress, nullptr,
                                   &timing, realtime);
    } else {
      haptics::LockstepRender render;
      if (recorder) render = fem_lockstep_frames(*recorder, model, fem, f.render_every_ticks);
      s = haptics::replay_lockstep(force, &fem, device, f.limits, &session, progress, nullptr,
                                   recorder ? &render : nullptr);
    }
    refuse_empty_run(f, s, bridged);
    force.write_attributes(session);
    write_summary_attributes(session, f, s, timing);
    if (f.realtime && !windowed) {
      session.write_array("timing/fem_step_ns", timing.relax_slice_ns, "ns");
      session.write_array("timing/fem_step_start_ns", timing.relax_slice_start_ns, "ns");
      session.set_attribute("summary_fem_step_p50_us", timing.relax_slice.p50_us);
      session.set_attribute("summary_fem_step_p99_us", timing.relax_slice.p99_us);
    }
    fem.write_session(session, time_s(0), device.rate_hz());
    if (bridged != nullptr) write_bridge_attributes(session, *bridged);
    if (recorder) write_render_attributes(session, f, *recorder, timing);
    haptics::write_proxy_mesh(session.file_handle(), model.proxy());
  } catch (...) {
    session.abandon();
    throw;
  }
  session.close();
  // One series per mesh: the run's, then each remesh's (fem/remesh_k/, as write_session).
  std::vector<haptics::XdmfSeries> series(fem.remeshes().size() + 1);
  for (std::size_t k = 0; k < series.size(); ++k) {
    const haptics::FemModel& mesh_model = k == 0 ? model : *fem.remeshes()[k - 1]->model;
    const std::string group = k == 0 ? "" : "/fem/remesh_" + std::to_string(k);
    series[k].mesh_group = group + "/mesh";
    series[k].vertex_count = mesh_model.mesh().vertex_count();
    series[k].tet_count = mesh_model.mesh().tet_count();
    series[k].displacement_dataset = (k == 0 ? std::string("/fem") : group) + "/displacement_mm";
  }
  for (const haptics::FemFrame& frame : fem.frames()) {
    series[frame.mesh].times_s.push_back(time_s(frame.tick));
  }
  haptics::write_xdmf_time_series(xdmf, std::filesystem::path(f.output).filename().string(),
                                  series);
  if (!f.trace_out.empty()) write_recorded_trace(f.output, f.trace_out);

  if (f.print_report) {
    std::printf("%s %s on %s (proxy FEM, %s %s) -> %s\n", windowed ? "sculpted with" : "replayed",
                run_source(f).c_str(), f.volume.c_str(), haptics::fem_solver_name(options.solver),
                haptics::fem_interaction_name(options.interaction), f.output.c_str());
    print_run_report(f, s, timing, device,
                     "(contact solve on the FEM's snapshot, " +
                         std::to_string(force.unconverged_solves()) + " unconverged)");
    const engine::fem::ConformingMeshReport& mesh = model.proxy().report;
    std::printf(
        "  mesh             %d vertices, %d tets, dihedral %.1f..%.1f deg, %zu fixed DOFs\n",
        mesh.vertex_count, mesh.tet_count, mesh.quality.min_dihedral_deg,
        mesh.quality.max_dihedral_deg, model.fixed_dofs().size());
    const std::string every = "every " + std::to_string(options.fem_every_ticks) + " ticks";
    std::printf("  fem              %llu steps (%s), %zu vertices grabbed\n",
                static_cast<unsigned long long>(fem.steps()),
                windowed     ? (every + ", paced by the clock").c_str()
                : f.realtime ? (std::to_string(options.fem_rate_hz) + " Hz thread").c_str()
                             : every.c_str(),
                fem.captured_vertices().size());
    if (f.realtime && !windowed) print_stats_line("fem steps", timing.relax_slice);
    for (const auto& remesh : fem.remeshes()) {
      const engine::fem::ConformingMeshReport& r = remesh->model->proxy().report;
      std::printf(
          "  remesh           %s at %.3f s: %d vertices, %d tets, built in %.0f ms, "
          "taken over at %.3f s\n",
          remesh->description.c_str(), time_s(remesh->change_tick) - time_s(0), r.vertex_count,
          r.tet_count, 1e3 * remesh->build_s, time_s(remesh->taken_tick) - time_s(0));
      if (options.interaction == haptics::FemInteraction::kGrab) {
        if (remesh->captured_vertices > 0) {
          std::printf("                   %d vertices grabbed on it\n", remesh->captured_vertices);
        } else {
          std::printf(
              "                   the grab let go: no free vertex within reach on it "
              "(its force went to zero at that step)\n");
        }
      }
    }
    if (fem.label_changes_not_taken() > 0) {
      std::printf("  remesh           %zu label change(s) not taken over: the run ended first\n",
                  fem.label_changes_not_taken());
    }
    std::printf("  paraview         %s (node displacements over time)\n", xdmf.c_str());
    if (recorder) {
      print_render_line(f, *recorder, timing);
      std::printf("  proxy render     %d resamples of the deformed volume, %.1f ms each (%s)\n",
                  recorder->resamples(),
                  recorder->resample_ms_total() / std::max(1, recorder->resamples()),
                  render::gradient_transform_name(recorder->setup().resample.gradient));
    }
    if (bridged != nullptr) print_bridge_lines(*bridged);
    print_run_footer(f, s);
  }
  return ReplayResult{s, timing, haptics::SculptSummary{}};
}

}  // namespace hapvox::cli
