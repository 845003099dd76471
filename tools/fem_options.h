#pragma once
// The proxy-FEM model's flags, shared by `hapvox mesh` and `hapvox replay --model fem`:
// the materials file, where the labels come from (a label volume, seeds, or the materials'
// intensity ranges) and how the mesh is built. docs/materials.md.

#include <CLI/CLI.hpp>
#include <optional>
#include <string>
#include <vector>

#include "engine/labels/label_map.h"
#include "engine/labels/materials.h"
#include "engine/proxy/incision_file.h"
#include "engine/proxy/proxy_mesh.h"
#include "haptics/fem_model.h"
#include "haptics/fem_remesh.h"
#include "tools/cli.h"
#include "tools/pick_options.h"

namespace hapvox::cli {

/// --materials, --labels, --seed, --seed-tolerance, --pick..., --spacing-mm, --boundary-levels.
struct FemCliOptions {
  std::string materials;           // the materials TOML file; required to build a mesh
  std::string labels;              // a label volume; "" for none
  std::vector<std::string> seeds;  // "X,Y,Z[:LABEL]" in world mm; LABEL defaults to 1, 2, ...
  double seed_tolerance = -1;      // < 0: 10 % of the intensity range (the flag takes >= 0)
  double spacing_mm = 0;           // 0: the volume box's shortest side / 8
  int boundary_levels = 2;
  PickCliOptions pick;  // --pick PX,PY[:LABEL]: seeds picked on the rendered image
};

/// How the FEM runs, for every command that runs it (`replay`, `render --model fem`):
/// --interaction, --fem-solver, --coupling-n-per-mm, --candidate-margin-mm,
/// --fem-every-ticks, --incision and (with `realtime`) --fem-rate-hz.
struct FemRunFlags {
  haptics::FemOptions options;
  std::string interaction = "press";
  std::string solver = "linear";
  std::string incision;  // --incision FILE (engine/proxy/incision_file.h); "" for none
  void add_to(CLI::App& app, bool realtime = true);
  /// The checked options, the tool radius half `tool_diameter_mm`; InputError naming the flag.
  haptics::FemOptions resolve(double tool_diameter_mm) const;
  /// The incision file, read and checked, when --incision was given (InputError naming it).
  std::optional<engine::proxy::IncisionFile> read_incision() const;
};

/// Makes the incision in a run (engine/proxy/incised_proxy.h): without at_s, or with
/// `from_start` (no trace to time it by), `proxy` is cut now; else the cut is made now too
/// (so a bad cut stops the run before it starts) and a mesh change takes it over at the tick
/// nearest at_s at `rate_hz`, appended to `changes`. Throws InputError(the file, ...) for an
/// at_s past the trace's `ticks` and for a cut the mesh rejects.
void plan_incision(const engine::proxy::IncisionFile& incision, bool from_start, std::size_t ticks,
                   double rate_hz, engine::proxy::ProxyMesh& proxy,
                   std::vector<haptics::LabelChange>& changes);

/// Registers the flags on `app`; `options` must outlive the parse. --materials is optional
/// here (replay's voxel model needs none): mark it required where a command always meshes.
void add_fem_options(CLI::App& app, FemCliOptions& options);

/// The files the options read (materials, label volume), for check_outputs_spare_inputs.
std::vector<InputPath> fem_inputs(const FemCliOptions& options);

/// A volume's labels and the materials file they index.
struct LabelledVolume {
  engine::labels::Materials materials;
  engine::labels::LabelMap labels;
};

/// Reads the materials and makes the labels of `volume_spec` (a volume file or generator,
/// read unmapped): from a label volume (--labels), seeds (--seed, --pick) or the file's
/// intensity ranges. A turned volume is refused with "VOLUME: `who` a volume whose index
/// axes are world x, y, z (...)".
LabelledVolume labelled_volume_from_cli(const std::string& volume_spec,
                                        const FemCliOptions& options, const std::string& who);

/// What a proxy mesh is built from: the materials, the labels and the mesh options.
struct ProxyInputs {
  engine::labels::Materials materials;
  engine::labels::LabelMap labels;
  engine::proxy::ProxyMeshOptions mesh;
};

/// Reads the materials and makes the labels of `volume_spec` (a volume file or generator,
/// read unmapped) as build_proxy_from_cli does, without meshing them.
ProxyInputs proxy_inputs_from_cli(const std::string& volume_spec, const FemCliOptions& options,
                                  const std::optional<engine::fem::Region>& tool_region);

/// The proxy mesh of `volume_spec` (a volume file or generator, read unmapped): reads the
/// materials, makes the labels and builds the mesh. Throws InputError naming the file or
/// flag at fault ("--materials" when none was given).
/// `tool_region`, when given, is refined ProxyMeshOptions::tool_levels further (the region
/// a replay's tool sweeps).
engine::proxy::ProxyMesh build_proxy_from_cli(
    const std::string& volume_spec, const FemCliOptions& options,
    const std::optional<engine::fem::Region>& tool_region = std::nullopt);

}  // namespace hapvox::cli
