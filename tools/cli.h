#pragma once
// Shared pieces of the `hapvox` command line: flag parsing helpers and the option groups
// several commands use (volume mapping, material, tool, trace columns, transform).

#include <CLI/CLI.hpp>
#include <Eigen/Core>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "engine/tool_force.h"
#include "engine/volume_io.h"
#include "haptics/replay.h"
#include "haptics/trace.h"

namespace hapvox::cli {

/// Parses "X,Y,Z" (three finite numbers). Throws InputError(flag, ...).
Eigen::Vector3d parse_vec3(const std::string& text, const std::string& flag);
/// "A,B,C" as numbers; InputError(flag, "expected a comma-separated list of numbers, ...").
std::vector<double> parse_number_list(const std::string& text, const std::string& flag);

/// `text` in single quotes for /bin/sh (embedded quotes escaped).
std::string shell_quoted(const std::string& text);
/// Writes `script` (a compiled-in Python text) to a temporary file, runs `python` on it
/// with `args` (each shell-quoted), removes the file, and returns the exit status (-1 when
/// the interpreter did not exit normally). Throws InputError when the file can't be written.
int run_python_script(const std::string& python, const char* script, const std::string& tag,
                      const std::vector<std::string>& args);

/// --threshold / --window flags.
struct MappingFlags {
  std::string threshold;  // "" or a number
  std::string window;     // "" or "LO,HI"
  void add_to(CLI::App& app);
  engine::IntensityMapping resolve() const;
};

/// --time-col, --pos-cols, --orientation-cols, --time-unit, --pos-unit.
struct TraceFlags {
  std::string time_col = "t";
  std::string pos_cols = "x,y,z";
  std::string orientation_cols;  // "W,X,Y,Z" quaternion columns; "" for none
  std::string time_unit = "s";
  std::string pos_unit = "mm";
  double rate_hz = 1000.0;
  double max_gap_s = 0.05;
  void add_to(CLI::App& app);
  haptics::TraceColumns columns() const;
};

/// --scale, --rotate-deg, --offset-mm, --fit.
struct TransformFlags {
  double scale = 1.0;
  std::string rotate_deg;
  std::string offset_mm;
  bool fit = false;
  void add_to(CLI::App& app);
  haptics::DeviceTransform resolve(const haptics::Trace& trace,
                                   const engine::DensityField& field) const;
  /// Without a trace (a live device): --fit is refused by the caller.
  haptics::DeviceTransform resolve_fixed() const;
};

/// --youngs-modulus-pa, --poisson, --tool-diameter-mm, --contact-law,
/// --reference-length-mm, --surface-density.
struct ForceFlags {
  engine::ToolForceOptions options;
  std::string contact_law = "hertz";
  bool surface_density_given = false;  // set by the parser when --surface-density is given
  void add_to(CLI::App& app);
  /// The options with the contact law set, after checking the law's flags (throws
  /// InputError).
  engine::ToolForceOptions resolve() const;
};

/// The command line as typed, recorded in session files.
void set_command_line(int argc, char** argv);
const std::string& command_line();

/// Registers each command on the top-level app.
void add_replay_command(CLI::App& app);
void add_check_timing_command(CLI::App& app);
void add_report_command(CLI::App& app);

/// `hapvox check-timing` found the loop outside its budget (exit code 3).
class TimingBudgetBroken : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
/// `hapvox validate` found the physics off its closed form (exit code 3).
class ValidationFailed : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
void add_info_command(CLI::App& app);
void add_bench_command(CLI::App& app);
void add_validate_command(CLI::App& app);  // tools/cmd_validate.cc
void add_trace_command(CLI::App& app);

/// Gives every numeric option of `app` and its subcommands the check of its stated range
/// (tools/option_ranges.cc), shown in its help: NaN ("--slip-ratio: must be a number, not
/// nan"), infinities but where the range allows them ("--youngs-modulus-pa: must be a finite
/// number, not inf") and values outside it ("--poisson: must lie in (-1, 0.5), not 0.7") are
/// refused as the command line is parsed. Throws std::logic_error naming a numeric option
/// with no range. Call once all options are added.
void check_numeric_options(CLI::App& app);

/// The same check of a value set in code (the API's loop options): InputError(option, ...)
/// with the command line's words, the value written as the shortest text that reads back.
void check_option_value(const std::string& option, double value);

/// Fails with InputError(flag, ...) when OUTPUT is empty, and otherwise as
/// engine::io::check_output_target: a missing folder, a link, a directory or special file at
/// OUTPUT, a name too long, OUTPUT.partial there (another run's, or a killed run's).
void check_output_path(const std::string& output, const std::string& flag);

/// Something a command writes: a file (written as PATH.partial, then renamed), or, with
/// `files_in_dir` (a regular expression on file names), a directory it writes such files
/// into (again each through NAME.partial).
struct OutputPath {
  std::string path;
  std::string flag;  // the flag that named it, for the message
  std::string files_in_dir;
};
/// Something a command reads: a path and what it is ("trace", "volume", ...).
struct InputPath {
  std::string path;
  std::string what;
};
/// "Volume file (.nrrd, ...), folder of DICOM slices, or generator (block, ...)", from the
/// format table (engine/io/formats.h).
std::string volume_help();

/// The files a volume spec reads: none for a generator, the file itself, and the data file
/// its header names (a detached NRRD, .mhd or .hdr header's); for a raw file's spec
/// ("ct.raw:dims=..."), the file it names.
std::vector<InputPath> volume_inputs(const std::string& spec);
/// A --transfer value that names a file rather than a preset, as an input; else none.
std::vector<InputPath> transfer_inputs(const std::string& spec);

/// Every command calls this before it writes anything: fails with InputError(OUTPUT, "FLAG
/// would overwrite the input WHAT INPUT") when an output (or its NAME.partial, or a file an
/// output directory receives) is an existing input file, and with InputError(OUTPUT, "FLAG
/// and FLAG2 name the same file") when two outputs would be one file. Paths are compared as files,
/// not as text: `./p.csv` and `p.csv`, symbolic and hard links to the same file all match.
void check_outputs_spare_inputs(const std::vector<OutputPath>& outputs,
                                const std::vector<InputPath>& inputs);

/// What deserves a warning before a replay of `trace_path` runs, one line each (without the
/// "hapvox: warning: " that print_warnings adds): a tool that stays wholly outside the
/// volume's box at every tick, and a tool that starts inside the material (its first
/// contact has no free position before it, so its force starts from zero there).
std::vector<std::string> replay_warnings(const std::string& trace_path,
                                         const engine::ToolForceModel& model,
                                         const haptics::TraceDevice& device);
/// Prints each as "hapvox: warning: LINE" on stderr, after what stdout holds so far.
void print_warnings(const std::vector<std::string>& warnings);

}  // namespace hapvox::cli
