// hapvox convert IN OUT: a volume from any format hapvox reads into any it writes, with
// its spacing, origin and direction (engine/io/formats.h). Scanner samples become
// densities through the intensity mapping flags; a density file hapvox wrote stays as is.

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "tools/cli.h"

namespace hapvox::cli {
namespace {

struct ConvertFlags {
  std::string input;
  std::string output;
  MappingFlags mapping;
};

void run_convert(const ConvertFlags& f) {
  const engine::io::VolumeFormat* out_format = engine::io::find_volume_format(f.output);
  if (out_format == nullptr || out_format->write == nullptr) {
    throw InputError(f.output, "unknown output format (expected " +
                                   engine::io::volume_extensions_text(", ", " or ", true) + ")");
  }
  check_output_path(f.output, "OUT");
  std::vector<OutputPath> outputs = {{f.output, "OUT", ""}};
  // A detached header's data file is written too: name it before anything is written.
  if (const std::string data = engine::io::companion_output(*out_format, f.output); !data.empty()) {
    outputs.push_back({data, "OUT", ""});
  }
  check_outputs_spare_inputs(outputs, volume_inputs(f.input));
  const engine::DensityField field = engine::load_volume(f.input, f.mapping.resolve());
  out_format->write(field, f.output);
  const Eigen::Vector3d lo = field.world_min_mm();
  const Eigen::Vector3d hi = field.world_max_mm();
  std::printf("%s -> %s (%s): %d x %d x %d voxels, total density %.6g\n", f.input.c_str(),
              f.output.c_str(), out_format->name, field.dims().x(), field.dims().y(),
              field.dims().z(), field.total_density());
  std::printf("  world box (LPS)  [%g, %g] x [%g, %g] x [%g, %g] mm\n", lo.x(), hi.x(), lo.y(),
              hi.y(), lo.z(), hi.z());
}

}  // namespace

void add_convert_command(CLI::App& app) {
  auto flags = std::make_shared<ConvertFlags>();
  CLI::App* cmd =
      app.add_subcommand("convert", "Write a volume in another format (" +
                                        engine::io::volume_extensions_text(", ", ", ", true) +
                                        "), keeping spacing, origin and direction");
  cmd->add_option("IN", flags->input, volume_help())->required();
  cmd->add_option("OUT", flags->output,
                  "File to write; its extension picks the format (" +
                      engine::io::volume_extensions_text(", ", ", ", true) + ")")
      ->required();
  flags->mapping.add_to(*cmd);
  cmd->callback([flags] { run_convert(*flags); });
}

}  // namespace hapvox::cli
