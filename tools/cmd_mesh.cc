// hapvox mesh VOLUME --materials M.toml [--labels L | --seed X,Y,Z[:LABEL] ...] -o MESH.h5:
// builds the proxy model's label-conforming tet mesh (Nakao), writes it with an XDMF file
// for ParaView beside it, and prints its report.

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "engine/errors.h"
#include "haptics/mesh_file.h"
#include "tools/cli.h"
#include "tools/fem_options.h"

namespace hapvox::cli {
namespace {

struct MeshFlags {
  std::string volume;
  std::string output;
  FemCliOptions fem;
};

void print_report(const MeshFlags& f, const engine::proxy::ProxyMesh& proxy) {
  const engine::fem::ConformingMeshReport& r = proxy.report;
  std::printf("%s: proxy mesh of %s\n", f.output.c_str(), f.volume.c_str());
  std::printf("  vertices         %d (%d fixed)\n", proxy.mesh.vertex_count(),
              engine::proxy::fixed_vertex_count(proxy));
  std::printf("  tets             %d\n", proxy.mesh.tet_count());
  std::printf("  dihedral angles  %.2f - %.2f deg\n", r.quality.min_dihedral_deg,
              r.quality.max_dihedral_deg);
  std::printf("  volume           %.6g mm^3\n", r.quality.total_volume_mm3);
  for (const auto& [label, volume] : r.volume_mm3_by_label) {
    const auto error = r.relative_volume_error_by_label.find(label);
    std::printf("  label %-10d %.6g mm^3, %+.2f %% of its voxels' volume\n", label, volume,
                error == r.relative_volume_error_by_label.end() ? NAN : 100 * error->second);
  }
  std::printf("  build time       %.3f s\n", r.build_seconds);
  std::printf("wrote %s and %s\n", f.output.c_str(), haptics::xdmf_path_for(f.output).c_str());
}

void run_mesh(const MeshFlags& f) {
  const std::string xdmf = haptics::xdmf_path_for(f.output);
  if (xdmf == f.output) {
    throw InputError(f.output, "-o must not end in .xdmf (the XDMF file is written beside it)");
  }
  check_output_path(f.output, "-o");
  std::vector<InputPath> inputs = volume_inputs(f.volume);
  for (InputPath& input : fem_inputs(f.fem)) inputs.push_back(std::move(input));
  check_outputs_spare_inputs({{f.output, "-o", ""}, {xdmf, "-o's XDMF file", ""}}, inputs);
  const engine::proxy::ProxyMesh proxy = build_proxy_from_cli(f.volume, f.fem);
  haptics::write_mesh_file(f.output, proxy);
  print_report(f, proxy);
}

}  // namespace

void add_mesh_command(CLI::App& app) {
  auto flags = std::make_shared<MeshFlags>();
  CLI::App* cmd = app.add_subcommand(
      "mesh", "Build the proxy model's tet mesh of a volume's labels (HDF5 + XDMF for ParaView)");
  cmd->add_option("volume", flags->volume, "Volume file (.nrrd, .nhdr, .vdb) or generator")
      ->required();
  cmd->add_option("-o,--output", flags->output, "Mesh file to write (.h5)")->required();
  add_fem_options(*cmd, flags->fem);
  cmd->get_option("--materials")->required();
  cmd->callback([flags] { run_mesh(*flags); });
}

}  // namespace hapvox::cli
