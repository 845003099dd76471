// hapvox convert IN OUT: a volume from any format hapvox reads into any it writes, with
// its spacing, origin and direction (engine/io/formats.h). Scanner samples become
// densities through the intensity mapping flags; a density file hapvox wrote stays as is.
// With --labels, IN is a label map and OUT gets its labels as integers.

#include <cstdint>
#include <cstdio>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/io/formats.h"
#include "tools/cli.h"

namespace hapvox::cli {
namespace {

struct ConvertFlags {
  std::string input;
  std::string output;
  MappingFlags mapping;
  bool labels = false;
};

void print_box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  std::printf("  world box (LPS)  [%g, %g] x [%g, %g] x [%g, %g] mm\n", lo.x(), hi.x(), lo.y(),
              hi.y(), lo.z(), hi.z());
}

// A label map: integers in, the smallest integer type that holds them out.
void convert_labels(const ConvertFlags& f, const engine::io::VolumeFormat& out_format) {
  const engine::RawVolume labels = engine::io::read_scalar_volume(f.input);
  const engine::io::WrittenVolume written = engine::io::labels_to_write(labels, f.input);
  out_format.write_labels(written, f.output);
  std::set<float> distinct(labels.intensity.begin(), labels.intensity.end());
  distinct.erase(0.0f);
  std::int64_t labelled = 0;
  for (const float v : labels.intensity) labelled += v != 0.0f ? 1 : 0;
  std::printf("%s -> %s (%s label map, %s): %d x %d x %d voxels, %lld labelled, %zu labels\n",
              f.input.c_str(), f.output.c_str(), out_format.name,
              engine::io::nrrd_type_name(written.type), labels.dims.x(), labels.dims.y(),
              labels.dims.z(), static_cast<long long>(labelled), distinct.size());
  // The voxel box's corners (voxel faces, half a voxel beyond the centres) in world.
  const engine::DensityField box(openvdb::FloatGrid::create(0.0f), labels.spacing_mm,
                                 labels.origin_mm, labels.dims, labels.direction);
  print_box(box.world_min_mm(), box.world_max_mm());
}

void run_convert(const ConvertFlags& f) {
  const engine::io::VolumeFormat& out_format = engine::io::written_format(f.output);
  check_output_path(f.output, "OUT");
  std::vector<OutputPath> outputs = {{f.output, "OUT", ""}};
  // A detached header's data file is written too: name it before anything is written.
  if (const std::string data = engine::io::companion_output(out_format, f.output); !data.empty()) {
    outputs.push_back({data, "OUT", ""});
  }
  check_outputs_spare_inputs(outputs, volume_inputs(f.input));
  if (f.labels) return convert_labels(f, out_format);
  const engine::DensityField field = engine::load_volume(f.input, f.mapping.resolve());
  out_format.write(field, f.output);
  std::printf("%s -> %s (%s): %d x %d x %d voxels, total density %.6g\n", f.input.c_str(),
              f.output.c_str(), out_format.name, field.dims().x(), field.dims().y(),
              field.dims().z(), field.total_density());
  print_box(field.world_min_mm(), field.world_max_mm());
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
  cmd->add_flag("--labels", flags->labels,
                "IN is a label map: write its labels as integers (uint8, uint16 or int32, the "
                "smallest that holds them) marked as a label map, not densities");
  cmd->callback([flags] { run_convert(*flags); });
}

}  // namespace hapvox::cli
