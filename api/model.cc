// hapvox::Model: a deformation model bound to a volume (include/hapvox/model.h).

#include <CLI/CLI.hpp>

#include "api/internal.h"
#include "engine/errors.h"

namespace hapvox {

Model Model::voxel(const Volume& volume, const ModelOptions& options) {
  // The options go through `hapvox replay`'s parser and checks (the positional trace and
  // --volume only fill required slots: nothing is read).
  std::vector<std::string> args = {"replay", "(api)", "--volume", volume.source(), "-o", "(api)"};
  const std::vector<std::string> flags = api::model_flags(options);
  args.insert(args.end(), flags.begin(), flags.end());
  cli::ReplayFlags f;
  const std::unique_ptr<CLI::App> parser = api::parse_replay_flags(args, f);
  if (f.model == "fem") {
    throw InputError("--model",
                     "fem needs the volume file and its labels: run it with "
                     "hapvox::replay (Model::voxel makes the voxel model)");
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
  if (!(f.relax_tolerance >= 0.0 && f.relax_tolerance <= 10.0)) {
    throw InputError("--relax-tolerance", "must lie in [0, 10]");
  }
  const engine::ToolForceOptions force = cli::voxel_force_options(f);
  engine::RelaxOptions relax;
  relax.tolerance = f.relax_tolerance;
  relax.normal_density = f.normal_density;
  haptics::RelaxBudget budget;
  budget.relax_voxels = f.relax_voxels_per_tick;
  auto elastic = std::make_unique<const engine::ToolForceModel>(volume.impl().field, force);
  return Model(std::make_shared<const Impl>(
      Impl{volume, options, force, relax, budget, std::move(elastic)}));
}

const Volume& Model::volume() const { return impl_->volume; }
const ModelOptions& Model::options() const { return impl_->options; }
double Model::tool_radius_mm() const { return 0.5 * impl_->force.tool.diameter_mm; }

}  // namespace hapvox
