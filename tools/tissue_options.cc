#include "tools/tissue_options.h"

#include <sstream>

#include "engine/errors.h"

namespace hapvox::cli {

void check_tissue_flags(const FemCliOptions& options, const MappingFlags& mapping) {
  if (options.materials.empty()) {
    if (!options.labels.empty()) throw InputError("--labels", "needs --materials");
    if (!options.seeds.empty()) throw InputError("--seed", "needs --materials");
    if (options.seed_tolerance >= 0) throw InputError("--seed-tolerance", "needs --materials");
    if (!options.pick.picks.empty()) throw InputError("--pick", "needs --materials");
    return;
  }
  const char* why =
      "is not used with --materials (the materials file gives each tissue its density)";
  if (!mapping.threshold.empty()) throw InputError("--threshold", why);
  if (!mapping.window.empty()) throw InputError("--window", why);
}

engine::labels::TissueVolume tissue_volume_from_cli(const std::string& volume_spec,
                                                    const FemCliOptions& options,
                                                    const engine::ToolForceOptions& force) {
  LabelledVolume labelled =
      labelled_volume_from_cli(volume_spec, options, "materials by tissue need");
  const engine::TissueMaterial command{"command line", force.material,
                                       force.plastic.yield_stress_pa};
  return engine::labels::tissue_volume(labelled.labels, labelled.materials, command);
}

void write_tissue_attributes(haptics::SessionWriter& session, const std::string& materials_path,
                             const engine::TissueMap& tissue) {
  session.set_attribute("materials", materials_path);
  // One line (`hapvox info` prints an attribute per line): the rows separated by "; ".
  std::ostringstream rows;
  for (const engine::TissueMaterial& m : tissue.materials()) {
    if (rows.tellp() > 0) rows << "; ";
    rows << m.name << ": E " << m.elastic.youngs_modulus_pa << " Pa, nu " << m.elastic.poisson_ratio
         << ", sigma_f " << m.yield_stress_pa << " Pa";
  }
  session.set_attribute("tissues", rows.str());
}

}  // namespace hapvox::cli
