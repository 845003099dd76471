// hapvox render VOLUME --model fem --materials M.toml [--trace T] -o DIR: the volume as
// Nakao's proxy mesh deforms it (render/proxy_resample.h), a frame every N ticks of a
// lockstep FEM replay of the trace (the stages of `replay --model fem`, no session); without
// a trace, stills or a turntable of the volume at rest through the same path.

#include <cstdio>
#include <memory>

#include "engine/errors.h"
#include "haptics/fem_model.h"
#include "tools/render_command.h"
#include "tools/replay_command.h"

namespace hapvox::cli {

void run_fem_render(const RenderCommandFlags& f) {
  // Check everything the user gave before reading big files or creating output.
  if (f.plastic) {
    throw InputError("--plastic", "needs --model voxel (the FEM model does not sculpt)");
  }
  if (f.fem_mesh.materials.empty()) throw InputError("--materials", "--model fem needs one");
  const haptics::FemOptions options = f.fem_run.resolve(f.force.options.tool.diameter_mm);
  const std::optional<engine::proxy::IncisionFile> incision = f.fem_run.read_incision();
  std::vector<InputPath> inputs = volume_inputs(f.volume);
  if (!f.trace_path.empty()) inputs.push_back({f.trace_path, "trace"});
  for (const InputPath& input : transfer_inputs(f.render.transfer)) inputs.push_back(input);
  for (const InputPath& input : fem_inputs(f.fem_mesh)) inputs.push_back(input);
  if (incision) inputs.push_back({incision->source, "incision file"});
  const std::string written = std::string(kFrameFileNames) + (f.video ? "|frames\\.mp4" : "");
  check_outputs_spare_inputs({{f.output, "--output", written}}, inputs);

  const engine::IntensityMapping mapping = f.mapping.resolve();
  const engine::DensityField field = engine::load_volume(f.volume, mapping);
  const RenderSetup setup = resolve_render_flags(f.render, f.volume, field);
  const std::unique_ptr<haptics::TraceDevice> device = render_trace_device(f, field);
  std::optional<engine::fem::Region> region;
  if (device) region = fem_tool_region(*device, options.tool_radius_mm);
  const ProxyInputs proxy_inputs = proxy_inputs_from_cli(f.volume, f.fem_mesh, region);
  engine::proxy::ProxyMesh proxy = engine::proxy::build_proxy_mesh(
      proxy_inputs.labels, proxy_inputs.materials, proxy_inputs.mesh);
  std::vector<haptics::LabelChange> changes;
  if (incision) {
    plan_incision(*incision, !device, device ? device->tick_count() : 0,
                  device ? device->rate_hz() : 1000.0, proxy, changes);
  }
  const haptics::FemModel model(std::move(proxy), options);

  // Everything the user gave is valid: only now the output and the GL context. A grab's
  // capture sphere is not drawn (it would hide what it holds), a press's tool is.
  FrameRecorder recorder(
      field, setup, f.output,
      options.interaction == haptics::FemInteraction::kPress ? options.tool_radius_mm : 0.0);
  recorder.use_proxy_mesh();
  if (!f.quiet) {
    std::printf("renderer: %s, OpenGL %s\n", recorder.context().renderer().c_str(),
                recorder.context().version().c_str());
  }
  std::uint64_t fem_steps = 0;
  std::size_t grabbed = 0;
  if (!device) {
    if (incision) {
      // At rest but for the incision: the FEM's static opening, K u = 0 with the cut's faces
      // held +-width/2 apart.
      recorder.deform(model.mesh(), 0,
                      model.linear().solve_mm(Eigen::VectorXd::Zero(model.prescribed_mm().size()),
                                              model.prescribed_mm()));
    }
    draw_stills(recorder, f.turntable);
  } else {
    auto handoff = std::make_unique<haptics::FemHandoff>();
    haptics::FemForceStage force(model, *handoff);
    haptics::FemBackgroundStage fem(model, *handoff, device->tool_position_mm(0));
    fem.set_label_changes(std::move(changes));
    haptics::LockstepRender render = fem_lockstep_frames(recorder, model, fem, f.every_ticks);
    haptics::replay_lockstep(force, &fem, *device, haptics::DeviceLimits{}, nullptr, {}, nullptr,
                             &render);
    fem_steps = fem.steps();
    grabbed = fem.captured_vertices().size();
  }
  if (!f.quiet) {
    const engine::fem::ConformingMeshReport& mesh = model.proxy().report;
    std::printf("proxy mesh %d vertices, %d tets, %zu fixed DOFs; ", mesh.vertex_count,
                mesh.tet_count, model.fixed_dofs().size());
    if (device) {
      std::printf("%llu FEM steps (%s, every %zu ticks), %zu vertices grabbed\n",
                  static_cast<unsigned long long>(fem_steps),
                  haptics::fem_interaction_name(options.interaction), options.fem_every_ticks,
                  grabbed);
    } else {
      std::printf("no trace: the volume at rest%s\n", incision ? ", the incision opened" : "");
    }
    if (incision) {
      std::printf("incision %s: %zu vertices held open %g mm wide%s\n", incision->source.c_str(),
                  model.proxy().prescribed_mm.size() / 3, incision->width_mm,
                  incision->at_s && device ? " (made at at_s)" : "");
    }
    std::printf("%d resamples of the deformed volume, %.1f ms each (%s)\n", recorder.resamples(),
                recorder.resample_ms_total() / std::max(1, recorder.resamples()),
                render::gradient_transform_name(setup.resample.gradient));
    const render::RenderSettings& s = setup.settings;
    std::printf("wrote %d frame%s of %dx%d to %s (%.1f ms a frame, %.1f fps%s)\n",
                recorder.frames(), recorder.frames() == 1 ? "" : "s", s.width, s.height,
                f.output.c_str(), recorder.frame_ms_total() / recorder.frames(),
                1000.0 * recorder.frames() / recorder.frame_ms_total(),
                s.shadows.enabled ? ", shadows" : "");
  }
}

}  // namespace hapvox::cli
