#pragma once
// What the public API's handles hold (include/hapvox/*.h declare them opaque), and the glue
// from its typed options to `hapvox replay`'s flags: the API parses its options with the
// command line's own parser (tools/replay_command.h), so defaults, checks and error
// messages are the CLI's.

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "api/volume_impl.h"
#include "engine/relax.h"
#include "engine/tool_force.h"
#include "haptics/device.h"
#include "haptics/fem_model.h"
#include "haptics/trace.h"
#include "haptics/voxel_model.h"
#include "hapvox/device.h"
#include "hapvox/model.h"
#include "hapvox/trace.h"
#include "hapvox/volume.h"
#include "tools/replay_command.h"

namespace hapvox {

struct Trace::Impl {
  haptics::Trace trace;
};

struct Model::Impl {
  Volume volume;
  ModelOptions options;
  engine::ToolForceOptions force;  // resolved as `hapvox replay` resolves them
  engine::RelaxOptions relax;
  haptics::RelaxBudget budget;
  double tool_radius_mm = 0.0;
  // The voxel model on the volume's own densities, for runs that do not change them
  // (elastic); null for the FEM model.
  std::unique_ptr<const engine::ToolForceModel> elastic;
  // The proxy-FEM model (mesh, factored stiffness, options): constant, shared by its runs.
  std::unique_ptr<const haptics::FemModel> fem;
};

struct Device::Impl {
  std::unique_ptr<haptics::Device> device;
  /// Where the tool is at tick 0 (volume mm), before the run: the FEM model makes its first
  /// snapshot there (a callback device is asked once; the loop's read of tick 0 reuses it).
  std::function<haptics::Vec3d()> first_tool_position_mm;
  /// The time of tick 0, once a run has read it.
  std::function<double()> first_time_s;
};

namespace api {

/// "%.17g": a double as a flag value that parses back to the same bits.
std::string flag_number(double value);

/// The flags that stand for `options` (only those set), e.g. {"--poisson", "0.3"}.
std::vector<std::string> model_flags(const ModelOptions& options);
std::vector<std::string> intensity_flags(const IntensityOptions& options);

/// Parses `args` (starting with "replay", as after `hapvox`) with `hapvox replay`'s own
/// flags into `flags`. A flag CLI11 refuses throws InputError("hapvox replay", its message).
/// Returns the parser, which `flags.fem_only_options` point into: keep it while `flags`
/// is used.
std::unique_ptr<CLI::App> parse_replay_flags(const std::vector<std::string>& args,
                                             cli::ReplayFlags& flags);

/// The command line `args` stand for, for the session's command_line attribute.
std::string command_text(const std::vector<std::string>& args);

/// A loop's clock: --rate-hz and --max-gap-s checked as the command line checks them
/// (cli::TraceFlags::columns), as resampling options.
haptics::ResampleOptions loop_clock(double rate_hz,
                                    double max_gap_s = haptics::ResampleOptions{}.max_gap_s);

/// Parses a model's options (ModelOptions as flags, behind --volume SOURCE) with `hapvox
/// replay`'s parser into `flags`, as parse_replay_flags. Nothing is read.
std::unique_ptr<CLI::App> parse_model_flags(const Volume& volume, const ModelOptions& options,
                                            cli::ReplayFlags& flags);

/// The device-to-volume transform, checked as --scale, --rotate-deg and --offset-mm are.
haptics::DeviceTransform device_transform(const DeviceTransform& transform);

}  // namespace api
}  // namespace hapvox
