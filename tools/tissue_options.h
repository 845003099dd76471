#pragma once
// Materials by tissue for the voxel model: `replay` and `check-timing` with --materials
// (and --labels, --seed or --pick, or the file's intensity ranges) give each voxel its
// label's density and material (engine/labels/tissue.h, docs/materials.md).

#include <string>

#include "engine/labels/tissue.h"
#include "engine/tool_force.h"
#include "haptics/session.h"
#include "tools/cli.h"
#include "tools/fem_options.h"

namespace hapvox::cli {

/// The label flags need --materials, and --materials takes the place of an intensity
/// mapping (--threshold, --window). InputError naming the flag.
void check_tissue_flags(const FemCliOptions& options, const MappingFlags& mapping);

/// The volume's labels made as for the proxy model, then its density and materials; row 0
/// of the table is the command's material and yield stress (`force`).
engine::labels::TissueVolume tissue_volume_from_cli(const std::string& volume_spec,
                                                    const FemCliOptions& options,
                                                    const engine::ToolForceOptions& force);

/// "materials" (the file) and "tissues" (each row's name, E, nu and sigma_f, rows separated
/// by "; ").
void write_tissue_attributes(haptics::SessionWriter& session, const std::string& materials_path,
                             const engine::TissueMap& tissue);

}  // namespace hapvox::cli
