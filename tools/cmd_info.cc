// hapvox info FILE: what a volume, trace or session file holds.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "engine/errors.h"
#include "engine/fem/strain.h"
#include "haptics/mesh_file.h"
#include "haptics/session.h"
#include "tools/cli.h"

namespace hapvox::cli {
namespace {

struct InfoFlags {
  std::string path;
  MappingFlags mapping;
  TraceFlags trace;
};

void print_field(const engine::DensityField& field) {
  const auto& d = field.dims();
  const auto& v = field.voxel_size_mm();
  const auto& o = field.origin_mm();
  std::printf("  dims             %d x %d x %d voxels\n", d.x(), d.y(), d.z());
  std::printf("  voxel size       %g x %g x %g mm\n", v.x(), v.y(), v.z());
  std::printf("  origin           %g, %g, %g mm (centre of voxel 0,0,0)\n", o.x(), o.y(), o.z());
  const auto& r = field.direction();
  // + 0.0: no "-0" for a flipped axis's zero components.
  std::printf("  direction        i (%g, %g, %g), j (%g, %g, %g), k (%g, %g, %g) in LPS\n",
              r(0, 0) + 0.0, r(1, 0) + 0.0, r(2, 0) + 0.0, r(0, 1) + 0.0, r(1, 1) + 0.0,
              r(2, 1) + 0.0, r(0, 2) + 0.0, r(1, 2) + 0.0, r(2, 2) + 0.0);
  const auto lo = field.world_min_mm();
  const auto hi = field.world_max_mm();
  std::printf("  extent           [%g, %g] x [%g, %g] x [%g, %g] mm\n", lo.x(), hi.x(), lo.y(),
              hi.y(), lo.z(), hi.z());
  std::printf("  active voxels    %llu (%.1f %% of the box)\n",
              static_cast<unsigned long long>(field.active_voxel_count()),
              100.0 * static_cast<double>(field.active_voxel_count()) /
                  std::max(1.0, d.cast<double>().prod()));
  std::printf("  total density    %.6g (voxels of normal density)\n", field.total_density());
}

void info_volume(const InfoFlags& f) {
  const engine::io::VolumeFormat* format = engine::io::find_volume_format(f.path);
  if (format != nullptr && format->holds_samples && !engine::is_generator_spec(f.path)) {
    const engine::RawVolume raw = format->read_samples(f.path);
    if (raw.holds_density) {
      // Written by hapvox: densities, read back as they are.
      std::printf("%s: %s volume, %s densities written by hapvox\n", f.path.c_str(), format->name,
                  raw.sample_type.c_str());
      std::printf("  density          %g .. %g\n", raw.min_intensity, raw.max_intensity);
    } else if (raw.holds_labels) {
      std::printf("%s: %s volume, %s label map\n", f.path.c_str(), format->name,
                  raw.sample_type.c_str());
      std::printf("  labels           %g .. %g\n", raw.min_intensity, raw.max_intensity);
    } else {
      std::printf("%s: %s volume, %s samples\n", f.path.c_str(), format->name,
                  raw.sample_type.c_str());
      std::printf("  intensity        %g .. %g (Otsu threshold %g)\n", raw.min_intensity,
                  raw.max_intensity, engine::otsu_threshold(raw));
    }
    print_field(engine::io::load_samples(raw, f.mapping.resolve(), f.path));
    return;
  }
  const engine::DensityField field = engine::load_volume(f.path, f.mapping.resolve());
  if (engine::is_generator_spec(f.path)) {
    std::printf("%s: generated density volume\n", f.path.c_str());
  } else {
    std::printf("%s: %s volume\n", f.path.c_str(), format->name);
  }
  print_field(field);
}

void info_trace(const InfoFlags& f) {
  const haptics::Trace trace = haptics::read_trace(f.path, f.trace.columns());
  const std::size_t n = trace.time_s.size();
  std::vector<double> steps(n - 1);
  for (std::size_t i = 1; i < n; ++i) steps[i - 1] = trace.time_s[i] - trace.time_s[i - 1];
  const auto gaps =
      std::count_if(steps.begin(), steps.end(), [&](double s) { return s > f.trace.max_gap_s; });
  Eigen::Vector3d lo = trace.position_mm[0];
  Eigen::Vector3d hi = lo;
  double path_mm = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    lo = lo.cwiseMin(trace.position_mm[i]);
    hi = hi.cwiseMax(trace.position_mm[i]);
    if (i > 0) path_mm += (trace.position_mm[i] - trace.position_mm[i - 1]).norm();
  }
  const double duration = trace.time_s.back() - trace.time_s.front();
  std::printf("%s: probe trace\n", f.path.c_str());
  std::printf("  samples          %zu over %.6g s (mean rate %.6g Hz)\n", n, duration,
              (n - 1) / duration);
  std::printf("  time step        min %.6g s, median %.6g s, max %.6g s\n",
              *std::min_element(steps.begin(), steps.end()), haptics::percentile(steps, 50.0),
              *std::max_element(steps.begin(), steps.end()));
  std::printf("  gaps             %td longer than %g s\n", gaps, f.trace.max_gap_s);
  std::printf("  bounding box     [%g, %g] x [%g, %g] x [%g, %g] mm (device space)\n", lo.x(),
              hi.x(), lo.y(), hi.y(), lo.z(), hi.z());
  std::printf("  path length      %.6g mm\n", path_mm);
}

void info_session(const std::string& path) {
  const haptics::SessionInfo info = haptics::read_session_info(path);
  std::printf("%s: hapvox session, %zu ticks, %s\n", path.c_str(), info.rows,
              info.complete ? "complete" : "INCOMPLETE (the run did not finish)");
  if (!info.complete && path.ends_with(".partial")) {
    std::printf("  recover it       hapvox recover %s\n", path.c_str());
  }
  std::printf("  datasets        ");
  for (const auto& name : info.datasets) std::printf(" %s", name.c_str());
  std::printf("\n");
  for (const auto& [name, value] : info.attributes) {
    std::printf("  %-28s %s\n", name.c_str(), value.c_str());
  }
}

// The /mesh group of a mesh file (`hapvox mesh`) or a session.
void print_mesh(const std::string& path) {
  const haptics::MeshFileInfo mesh = haptics::read_mesh_info(path);
  std::printf("  mesh             %d vertices (%d fixed), %d tets\n", mesh.vertex_count,
              mesh.fixed_vertex_count, mesh.tet_count);
  std::printf("  dihedral angles  %.2f - %.2f deg\n", mesh.min_dihedral_deg, mesh.max_dihedral_deg);
  std::printf("  materials        %s\n", mesh.materials_source.c_str());
  for (const auto& [label, l] : mesh.labels) {
    std::printf("  label %-10d %d tets, %.6g mm^3 (%+.2f %% of its voxels'), E %g Pa, nu %g\n",
                label, l.tet_count, l.volume_mm3, 100 * l.relative_volume_error, l.youngs_pa,
                l.poisson);
  }
}

// A FEM session's strain at its last FEM step, per label (Nakao's Fig. 5 compares these), on
// the mesh that step solved on: the run's, or its last remesh's (fem/remesh_k/).
void print_fem_strain(const std::string& path, int remeshes) {
  const std::string group = remeshes == 0 ? "fem/" : "fem/remesh_" + std::to_string(remeshes) + "/";
  const engine::fem::TetMesh mesh =
      haptics::read_tet_mesh(path, remeshes == 0 ? "mesh" : group + "mesh");
  const std::vector<double> steps = haptics::read_session_column(path, group + "step_tick");
  const std::vector<double> all = haptics::read_session_column(path, group + "displacement_mm");
  const std::size_t per_step = 3 * static_cast<std::size_t>(mesh.vertex_count());
  if (steps.empty() || all.size() != steps.size() * per_step) {
    throw InputError(
        path, group + "displacement_mm is not (" + group + "step_tick's length) x vertices x 3");
  }
  const Eigen::VectorXd last = Eigen::Map<const Eigen::VectorXd>(
      all.data() + (steps.size() - 1) * per_step, static_cast<Eigen::Index>(per_step));
  if (remeshes > 0) {
    std::printf(
        "  remeshes         %d (labels changed during the run); the last: %d vertices, "
        "%d tets\n",
        remeshes, mesh.vertex_count(), mesh.tet_count());
  }
  std::printf("  strain at the last FEM step (tick %.0f), volume-weighted per label:\n",
              steps.back());
  for (const auto& [label, s] : engine::fem::mean_strain_by_label(mesh, last)) {
    std::printf("  label %-10d mean |eps| %.4e, mean equivalent %.4e, max |eps| %.4e\n", label,
                s.mean_strain_norm, s.mean_equivalent_strain, s.max_strain_norm);
  }
}

void run_info(const InfoFlags& f) {
  namespace fs = std::filesystem;
  if (engine::is_generator_spec(f.path) || engine::io::find_volume_format(f.path) != nullptr) {
    info_volume(f);
    return;
  }
  std::string ext = fs::path(f.path).extension().string();
  // An unfinished output (a killed run's session.h5.partial) is read as what it will be.
  if (ext == ".partial") ext = fs::path(f.path).stem().extension().string();
  if (!fs::exists(f.path)) throw InputError(f.path, "cannot open file");
  if (ext == ".csv") {
    info_trace(f);
    return;
  }
  if (ext == ".h5" || ext == ".hdf5") {
    if (!haptics::is_hdf5_file(f.path)) throw InputError(f.path, "not an HDF5 file");
    const haptics::SessionInfo probe = [&] {
      try {
        return haptics::read_session_info(f.path);
      } catch (const InputError&) {
        return haptics::SessionInfo{};
      }
    }();
    if (!probe.datasets.empty()) {
      info_session(f.path);
      if (haptics::has_mesh_group(f.path)) {
        print_mesh(f.path);
        const auto& names = probe.datasets;
        const auto has = [&](const std::string& name) {
          return std::find(names.begin(), names.end(), name) != names.end();
        };
        if (has("/fem/displacement_mm")) {
          int remeshes = 0;
          while (has("/fem/remesh_" + std::to_string(remeshes + 1) + "/displacement_mm")) {
            ++remeshes;
          }
          print_fem_strain(f.path, remeshes);
        }
      }
    } else if (haptics::has_mesh_group(f.path)) {
      std::printf("%s: hapvox proxy mesh\n", f.path.c_str());
      print_mesh(f.path);
    } else {
      info_trace(f);
    }
    return;
  }
  throw InputError(f.path, "unknown file type '" + ext + "' (expected a volume " +
                               engine::io::volume_extensions_text("/", "/") +
                               ", a trace .csv/.h5, or a session .h5)");
}

}  // namespace

void add_info_command(CLI::App& app) {
  auto flags = std::make_shared<InfoFlags>();
  CLI::App* cmd = app.add_subcommand(
      "info", "Describe a volume (" + engine::io::volume_extensions_text(", ", ", ") +
                  ", generator), trace (.csv, .h5), session or mesh");
  cmd->add_option("file", flags->path, "File or generator to describe")->required();
  flags->mapping.add_to(*cmd);
  flags->trace.add_to(*cmd);
  cmd->callback([flags] { run_info(*flags); });
}

}  // namespace hapvox::cli
