// hapvox::Model: a deformation model bound to a volume (include/hapvox/model.h).

#include <CLI/CLI.hpp>

#include "api/internal.h"
#include "engine/errors.h"
#include "tools/fem_options.h"

namespace hapvox {

Model Model::voxel(const Volume& volume, const ModelOptions& options) {
  // The options go through `hapvox replay`'s parser and checks.
  cli::ReplayFlags f;
  const std::unique_ptr<CLI::App> parser = api::parse_model_flags(volume, options, f);
  if (f.model == "fem") {
    throw InputError("--model", "Model::voxel makes the voxel model: use Model::fem");
  }
  if (f.model != "voxel") {
    throw InputError("--model", "unknown model '" + f.model + "' (voxel or fem)");
  }
  if (!f.fem_mesh.materials.empty()) {
    throw InputError("--materials",
                     "materials by tissue need the volume's labels: run them "
                     "with hapvox::replay");
  }
  for (const CLI::Option* option : f.fem_only_options) {
    if (option->count() > 0) throw InputError(option->get_name(), "needs --model fem");
  }
  const engine::ToolForceOptions force = cli::voxel_force_options(f);
  engine::RelaxOptions relax;
  relax.tolerance = f.relax_tolerance;
  relax.normal_density = f.normal_density;
  haptics::RelaxBudget budget;
  budget.relax_voxels = f.relax_voxels_per_tick;
  auto elastic = std::make_unique<const engine::ToolForceModel>(volume.impl().field, force);
  return Model(std::make_shared<const Impl>(Impl{volume, options, force, relax, budget,
                                                 0.5 * force.tool.diameter_mm, std::move(elastic),
                                                 nullptr}));
}

Model Model::fem(const Volume& volume, const ModelOptions& options) {
  if (volume.source() == "array") {
    throw InputError("array",
                     "the proxy-FEM model reads its labels from a volume file or "
                     "generator: save the array (Volume::save) and load that");
  }
  ModelOptions fem_options = options;
  fem_options.model = "fem";
  cli::ReplayFlags f;
  const std::unique_ptr<CLI::App> parser = api::parse_model_flags(volume, fem_options, f);
  // `hapvox replay --model fem`'s checks (tools/replay_fem.cc), in its words.
  if (f.plastic) {
    throw InputError("--plastic", "needs --model voxel (the FEM model does not sculpt)");
  }
  if (f.fem_mesh.materials.empty()) throw InputError("--materials", "--model fem needs one");
  if (!f.relabels.empty()) {
    throw InputError("--relabel", "needs a trace (its times are trace times): use hapvox::replay");
  }
  if (!f.fem_run.incision.empty()) {
    throw InputError("--incision", "cuts in a replay: use hapvox::replay");
  }
  const haptics::FemOptions fem = f.fem_run.resolve(f.force.options.tool.diameter_mm);
  const cli::ProxyInputs inputs = cli::proxy_inputs_from_cli(volume.source(), f.fem_mesh, {});
  auto model = std::make_unique<const haptics::FemModel>(
      engine::proxy::build_proxy_mesh(inputs.labels, inputs.materials, inputs.mesh), fem);
  return Model(std::make_shared<const Impl>(Impl{volume,
                                                 fem_options,
                                                 f.force.options,
                                                 {},
                                                 {},
                                                 fem.tool_radius_mm,
                                                 nullptr,
                                                 std::move(model)}));
}

const Volume& Model::volume() const { return impl_->volume; }
const ModelOptions& Model::options() const { return impl_->options; }
double Model::tool_radius_mm() const { return impl_->tool_radius_mm; }

}  // namespace hapvox
