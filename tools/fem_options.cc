#include "tools/fem_options.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <memory>

#include "engine/errors.h"
#include "engine/labels/label_map.h"
#include "engine/labels/materials.h"
#include "engine/proxy/incised_proxy.h"
#include "engine/proxy/label_source.h"

namespace hapvox::cli {

void FemRunFlags::add_to(CLI::App& app, bool realtime) {
  app.add_option("--interaction", interaction,
                 "fem: press (the tool sphere pushes) or grab (the vertices within the tool "
                 "radius of the first position follow it)")
      ->capture_default_str();
  app.add_option("--fem-solver", solver, "fem: linear or corotational")->capture_default_str();
  app.add_option("--coupling-n-per-mm", options.coupling_n_per_mm,
                 "fem: virtual coupling stiffness, N/mm (the rendered stiffness never exceeds "
                 "it; passive at 1 kHz for a device damping >= k T / 2)")
      ->capture_default_str();
  app.add_option("--candidate-margin-mm", options.candidate_margin_mm,
                 "fem press: surface vertices this close to the tool join the contact snapshot")
      ->capture_default_str();
  app.add_option("--fem-every-ticks", options.fem_every_ticks,
                 "fem, lockstep: one FEM step every N ticks")
      ->capture_default_str();
  if (realtime) {
    app.add_option("--fem-rate-hz", options.fem_rate_hz, "fem, realtime: the FEM thread's rate")
        ->capture_default_str();
  }
  app.add_option("--fem-steps-kept-mb", options.kept_steps_mb,
                 "fem: memory for the FEM steps' displacements kept for the session; beyond it "
                 "only every 2nd (4th, ...) step is kept, over the whole run")
      ->capture_default_str();
  app.add_option("--incision", incision,
                 "fem: an incision file (TOML: width_mm, polyline_mm + sweep_mm or triangles_mm, "
                 "at_s; docs/formats.md): the proxy mesh is cut and held open by the width");
}

std::optional<engine::proxy::IncisionFile> FemRunFlags::read_incision() const {
  if (incision.empty()) return std::nullopt;
  return engine::proxy::read_incision(incision);
}

void plan_incision(const engine::proxy::IncisionFile& incision, bool from_start, std::size_t ticks,
                   double rate_hz, engine::proxy::ProxyMesh& proxy,
                   std::vector<haptics::LabelChange>& changes) {
  auto incised = std::make_shared<const engine::proxy::ProxyMesh>(
      engine::proxy::incise(proxy, incision.cut, incision.width_mm, incision.source));
  if (from_start || !incision.at_s) {
    proxy = *incised;
    return;
  }
  // Compared as a double first: llround of a time far past the end is out of range.
  const double tick_d = std::round(*incision.at_s * rate_hz);
  if (!(tick_d < static_cast<double>(ticks))) {
    char what[160];
    std::snprintf(what, sizeof what, "at_s %g s is past the trace's end (%g s)", *incision.at_s,
                  static_cast<double>(ticks) / rate_hz);
    throw InputError(incision.source, what);
  }
  haptics::LabelChange change;
  change.tick = static_cast<std::int64_t>(tick_d);
  change.description = "incision " + incision.source;
  change.build_proxy = [incised] { return *incised; };
  changes.push_back(std::move(change));
  std::stable_sort(changes.begin(), changes.end(),
                   [](const auto& a, const auto& b) { return a.tick < b.tick; });
}

haptics::FemOptions FemRunFlags::resolve(double tool_diameter_mm) const {
  haptics::FemOptions o = options;
  o.interaction = haptics::parse_fem_interaction(interaction, "--interaction");
  o.solver = haptics::parse_fem_solver(solver, "--fem-solver");
  o.tool_radius_mm = 0.5 * tool_diameter_mm;
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(o.tool_radius_mm)) throw InputError("--tool-diameter-mm", "must be positive");
  if (!positive(o.coupling_n_per_mm)) throw InputError("--coupling-n-per-mm", "must be positive");
  if (!std::isfinite(o.candidate_margin_mm) || o.candidate_margin_mm < 0.0) {
    throw InputError("--candidate-margin-mm", "must be zero or positive");
  }
  if (o.fem_every_ticks == 0) throw InputError("--fem-every-ticks", "must be at least 1");
  if (!positive(o.kept_steps_mb)) throw InputError("--fem-steps-kept-mb", "must be positive");
  if (!(o.fem_rate_hz >= 1.0 && o.fem_rate_hz <= 1000.0)) {
    throw InputError("--fem-rate-hz", "must lie in [1, 1000]");
  }
  return o;
}

namespace {

// "X,Y,Z[:LABEL]"; a seed without a label gets `default_label`.
engine::labels::Seed parse_seed(const std::string& text, engine::labels::Label default_label) {
  engine::labels::Seed seed;
  const std::size_t colon = text.find(':');
  seed.point_mm = parse_vec3(text.substr(0, colon), "--seed");
  seed.label = default_label;
  if (colon != std::string::npos) {
    const std::string label = text.substr(colon + 1);
    const auto [end, ec] = std::from_chars(label.data(), label.data() + label.size(), seed.label);
    if (ec != std::errc() || end != label.data() + label.size() || label.empty() ||
        seed.label <= 0 || seed.label > engine::labels::kMaxLabel) {
      throw InputError("--seed", "expected a label in [1, " +
                                     std::to_string(engine::labels::kMaxLabel) +
                                     "] after ':', got '" + label + "'");
    }
  }
  return seed;
}

}  // namespace

void add_fem_options(CLI::App& app, FemCliOptions& options) {
  app.add_option(
      "--materials", options.materials,
      "Materials TOML file: per label E, nu, fixed (the proxy mesh), density and yield stress "
      "(the voxel model's materials by tissue); docs/materials.md");
  auto* labels = app.add_option("--labels", options.labels,
                                "Label volume (integer voxels, same grid as the volume)");
  auto* seeds = app.add_option("--seed", options.seeds,
                               "X,Y,Z[:LABEL] (mm): grow LABEL's region from this point "
                               "(repeatable; labels default to 1, 2, ...)")
                    ->allow_extra_args(false);  // one value per --seed: VOLUME may follow
  labels->excludes(seeds);
  add_pick_options(app, options.pick);
  labels->excludes(app.get_option("--pick"));
  app.add_option("--seed-tolerance", options.seed_tolerance,
                 "Intensity difference a seed's region accepts (default: 10 % of the "
                 "volume's intensity range)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--spacing-mm", options.spacing_mm,
                 "Mesh lattice spacing (default: the volume's shortest side / 8)")
      ->check(CLI::PositiveNumber);
  app.add_option("--boundary-levels", options.boundary_levels,
                 "Halvings of the spacing at label boundaries (0-8)")
      ->capture_default_str()
      ->check(CLI::Range(0, 8));
}

std::vector<InputPath> fem_inputs(const FemCliOptions& options) {
  std::vector<InputPath> inputs;
  if (!options.materials.empty()) inputs.push_back({options.materials, "materials file"});
  for (InputPath& label : volume_inputs(options.labels)) {
    label.what = label.what == "volume" ? "label volume" : "label volume data file";
    inputs.push_back(std::move(label));
  }
  return inputs;
}

LabelledVolume labelled_volume_from_cli(const std::string& volume_spec,
                                        const FemCliOptions& options, const std::string& who) {
  if (options.materials.empty()) {
    throw InputError("--materials", "the proxy model needs a materials file");
  }
  // The cheap checks first: a bad materials file or seed fails before the volume is read.
  engine::labels::Materials materials = engine::labels::read_materials(options.materials);
  engine::proxy::LabelSourceOptions source;
  source.intensity_name = volume_spec;
  source.label_volume = options.labels;
  for (std::size_t i = 0; i < options.seeds.size(); ++i) {
    source.seeds.push_back(parse_seed(options.seeds[i], static_cast<int>(i) + 1));
  }
  const std::vector<PixelPick> picks =
      parse_picks(options.pick, static_cast<int>(source.seeds.size()) + 1);
  if (options.seed_tolerance >= 0) source.seed_tolerance = options.seed_tolerance;
  const engine::RawVolume intensity = engine::labels::read_scalar_volume(volume_spec);
  if (intensity.direction != engine::Mat3d::Identity()) {
    // Label maps are axis-aligned; turning them (and seeds) into the volume's frame is not
    // done yet.
    throw InputError(volume_spec, who +
                                      " a volume whose index axes are world x, y, z "
                                      "(this one's direction cosines are not the identity)");
  }
  for (const auto& seed : seeds_from_picks(intensity, volume_spec, options.pick, picks)) {
    source.seeds.push_back(seed);
  }
  engine::labels::LabelMap labels = engine::proxy::proxy_labels(intensity, materials, source);
  return LabelledVolume{std::move(materials), std::move(labels)};
}

ProxyInputs proxy_inputs_from_cli(const std::string& volume_spec, const FemCliOptions& options,
                                  const std::optional<engine::fem::Region>& tool_region) {
  LabelledVolume labelled =
      labelled_volume_from_cli(volume_spec, options, "the proxy-FEM model needs");
  engine::proxy::ProxyMeshOptions mesh_options;
  mesh_options.coarse_spacing_mm = options.spacing_mm;
  mesh_options.boundary_levels = options.boundary_levels;
  mesh_options.tool_region = tool_region;
  return ProxyInputs{std::move(labelled.materials), std::move(labelled.labels), mesh_options};
}

engine::proxy::ProxyMesh build_proxy_from_cli(
    const std::string& volume_spec, const FemCliOptions& options,
    const std::optional<engine::fem::Region>& tool_region) {
  const ProxyInputs inputs = proxy_inputs_from_cli(volume_spec, options, tool_region);
  return engine::proxy::build_proxy_mesh(inputs.labels, inputs.materials, inputs.mesh);
}

}  // namespace hapvox::cli
