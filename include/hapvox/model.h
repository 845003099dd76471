#pragma once
// The deformation model a tool feels, and its materials.
//
//   voxel  Prados et al.: linear-elastic (and, with `plastic`, incremental-plasticity) tool
//          forces straight from the density field; sculpting deletes and relaxes voxels
//          with the clay's mass conserved.
//   fem    Nakao et al.: an adaptive tetrahedral proxy mesh of the labelled volume with
//          linear or co-rotational FEM; a materials file gives each label E, nu and whether
//          it is fixed; the tool presses or grabs (--interaction).
//
// Every option left unset takes `hapvox replay`'s default, and every value is checked as
// the command line checks it: a bad one throws InputError naming the flag, with the CLI's
// words (e.g. "--poisson: Poisson's ratio must lie in (-1, 0.5), got 0.7").

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hapvox/volume.h"

namespace hapvox {

struct ModelOptions {
  std::string model = "voxel";              // --model: "voxel" or "fem"
  std::optional<double> youngs_modulus_pa;  // --youngs-modulus-pa
  std::optional<double> poisson_ratio;      // --poisson
  std::optional<double> tool_diameter_mm;   // --tool-diameter-mm (a sphere)
  std::string contact_law;                  // --contact-law: "" (hertz) or "paper"
  bool plastic = false;                     // --plastic (voxel): sculpting
  std::optional<double> yield_stress_pa;    // --yield-stress-pa (plastic)
  std::string materials;                    // --materials FILE.toml (fem; voxel by tissue)
  std::string labels;                       // --labels VOLUME (fem; voxel by tissue)
  /// Any other `hapvox replay` model flag as typed on the command line, e.g.
  /// {"--fem-solver", "corotational", "--spacing-mm", "4"} (docs/api.md lists them).
  std::vector<std::string> flags;
};

/// A model bound to a volume: constant once made (MuJoCo's mjModel). Every run or
/// ForceStage made from it keeps its own mutable state (a sculpted copy of the densities),
/// so one Model serves many runs, one after another or on several threads.
class Model {
 public:
  /// The voxel model on `volume`. Throws InputError for a bad option, for materials by
  /// tissue (those run through hapvox::replay) and for options.model "fem" (Model::fem).
  static Model voxel(const Volume& volume, const ModelOptions& options = {});

  /// The proxy-FEM model (options.model is taken as "fem"): the labels of the file or
  /// generator `volume` was loaded from (a label volume with options.labels, else the
  /// materials' intensity ranges) meshed and its stiffness factored here, once. The mesh is
  /// not refined along a tool path (none is known ahead: `hapvox replay --no-tool-refine`).
  /// Needs options.materials. Throws InputError for a bad option, a volume made from an
  /// array (save it and load the file), and --relabel or --incision (hapvox::replay runs
  /// those).
  static Model fem(const Volume& volume, const ModelOptions& options);

  const Volume& volume() const;
  const ModelOptions& options() const;
  /// The tool sphere's radius, mm.
  double tool_radius_mm() const;

  struct Impl;
  const Impl& impl() const { return *impl_; }

 private:
  explicit Model(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}
  std::shared_ptr<const Impl> impl_;
};

}  // namespace hapvox
