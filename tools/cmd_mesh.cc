// hapvox mesh VOLUME --materials M.toml [--labels L | --seed X,Y,Z[:LABEL] ...] -o MESH.h5:
// builds the proxy model's label-conforming tet mesh (Nakao), writes it with an XDMF file
// for ParaView beside it, and prints its report.

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "engine/errors.h"
#include "engine/io/formats.h"
#include "engine/labels/label_map.h"
#include "engine/proxy/tetgen_files.h"
#include "haptics/mesh_file.h"
#include "tools/cli.h"
#include "tools/fem_options.h"
#include "tools/tetgen_compare.h"

namespace hapvox::cli {
namespace {

struct MeshFlags {
  std::string volume;
  std::string output;
  FemCliOptions fem;
  std::string tetgen_out;  // PREFIX: .node/.ele of the mesh and .smesh of its surfaces
  std::string tetgen;      // the TetGen program to compare with ("" for none)
  std::string labels_out;  // the label map the mesh was built from ("" for none)
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
  if (!f.tetgen.empty() && f.tetgen_out.empty()) {
    throw InputError("--tetgen", "needs --tetgen-out PREFIX (where TetGen's files go)");
  }
  if (!f.tetgen.empty()) check_tetgen_program(f.tetgen);
  std::vector<OutputPath> outputs{{f.output, "-o", ""}, {xdmf, "-o's XDMF file", ""}};
  if (!f.tetgen_out.empty()) {
    for (const char* ext :
         {".node", ".ele", ".smesh", ".1.node", ".1.ele", ".1.face", ".1.edge", ".tetgen.log"}) {
      outputs.push_back({f.tetgen_out + ext, "--tetgen-out", ""});
    }
  }
  if (!f.labels_out.empty()) {
    const engine::io::VolumeFormat& format = engine::io::written_format(f.labels_out);
    check_output_path(f.labels_out, "--labels-out");
    outputs.push_back({f.labels_out, "--labels-out", ""});
    if (const std::string data = engine::io::companion_output(format, f.labels_out);
        !data.empty()) {
      outputs.push_back({data, "--labels-out", ""});
    }
  }
  check_outputs_spare_inputs(outputs, inputs);
  const ProxyInputs inputs_read = proxy_inputs_from_cli(f.volume, f.fem, std::nullopt);
  const engine::proxy::ProxyMesh proxy =
      engine::proxy::build_proxy_mesh(inputs_read.labels, inputs_read.materials, inputs_read.mesh);
  haptics::write_mesh_file(f.output, proxy);
  print_report(f, proxy);
  if (!f.labels_out.empty()) {
    engine::io::write_label_volume(engine::labels::label_samples(inputs_read.labels), f.volume,
                                   f.labels_out);
    std::printf("wrote %s (the label map the mesh was built from)\n", f.labels_out.c_str());
  }
  if (!f.tetgen_out.empty()) {
    engine::proxy::write_tetgen_mesh(f.tetgen_out, proxy.mesh);
    const int facets = engine::proxy::write_tetgen_surface(f.tetgen_out, proxy.mesh);
    std::printf(
        "wrote %s.node and %s.ele (the mesh, label as region attribute) and %s.smesh "
        "(%d facets: its surface and label boundaries; tetgen -pY meshes it)\n",
        f.tetgen_out.c_str(), f.tetgen_out.c_str(), f.tetgen_out.c_str(), facets);
  }
  if (f.tetgen.empty()) return;
  const TetgenMesh tetgen = mesh_with_tetgen(proxy, f.tetgen, f.tetgen_out);
  const engine::fem::ConformingMeshReport& r = proxy.report;
  std::printf("TetGen (%s -pYqQ %s.smesh, %.3f s) beside hapvox's mesh:\n", f.tetgen.c_str(),
              f.tetgen_out.c_str(), tetgen.seconds);
  std::printf("  %-16s %14s %14s\n", "", "hapvox", "TetGen");
  std::printf("  %-16s %14d %14d\n", "vertices", proxy.mesh.vertex_count(),
              tetgen.mesh.vertex_count());
  std::printf("  %-16s %14d %14d\n", "tets", proxy.mesh.tet_count(), tetgen.mesh.tet_count());
  std::printf("  %-16s %14.2f %14.2f\n", "min dihedral deg", r.quality.min_dihedral_deg,
              tetgen.quality.min_dihedral_deg);
  std::printf("  %-16s %14.2f %14.2f\n", "max dihedral deg", r.quality.max_dihedral_deg,
              tetgen.quality.max_dihedral_deg);
  for (const auto& [label, volume] : r.volume_mm3_by_label) {
    const auto other = tetgen.volume_mm3_by_label.find(label);
    std::printf("  label %-10d %14.6g %14.6g mm^3\n", label, volume,
                other == tetgen.volume_mm3_by_label.end() ? 0.0 : other->second);
  }
  std::printf("wrote %s.1.node and %s.1.ele (TetGen's mesh; its log: %s.tetgen.log)\n",
              f.tetgen_out.c_str(), f.tetgen_out.c_str(), f.tetgen_out.c_str());
}

}  // namespace

void add_mesh_command(CLI::App& app) {
  auto flags = std::make_shared<MeshFlags>();
  CLI::App* cmd = app.add_subcommand(
      "mesh", "Build the proxy model's tet mesh of a volume's labels (HDF5 + XDMF for ParaView)");
  cmd->add_option("volume", flags->volume, volume_help())->required();
  cmd->add_option("-o,--output", flags->output, "Mesh file to write (.h5)")->required();
  add_fem_options(*cmd, flags->fem);
  cmd->get_option("--materials")->required();
  cmd->add_option("--labels-out", flags->labels_out,
                  "Also write the label map the mesh was built from (seeds, picks, intensity "
                  "ranges or --labels) as integers, for Slicer or ITK-SNAP (" +
                      engine::io::volume_extensions_text(", ", ", ", true) + ")");
  cmd->add_option("--tetgen-out", flags->tetgen_out,
                  "Also write PREFIX.node/.ele (the mesh) and PREFIX.smesh (its surface and "
                  "label boundaries) in TetGen's formats, to compare with TetGen's mesh");
  cmd->add_option("--tetgen", flags->tetgen,
                  "Run this TetGen program (e.g. tetgen; AGPL, never linked: Debian's "
                  "package) on --tetgen-out's surface and compare its mesh with hapvox's");
  cmd->callback([flags] { run_mesh(*flags); });
}

}  // namespace hapvox::cli
