#include "tools/cli.h"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <regex>
#include <sstream>
#include <system_error>

#include "engine/errors.h"
#include "engine/io/intensity.h"
#include "engine/io/output_file.h"
#include "render/transfer_function.h"

namespace hapvox::cli {
namespace {

double parse_number(const std::string& text, const std::string& flag) {
  double value = 0.0;
  const char* begin = text.data();
  const char* end = text.data() + text.size();
  while (begin < end && *begin == ' ') ++begin;
  const auto [ptr, ec] = std::from_chars(begin, end, value);
  if (ec != std::errc() || ptr != end || !std::isfinite(value)) {
    throw InputError(flag, "not a finite number: '" + text + "'");
  }
  return value;
}

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> parts;
  std::stringstream in(text);
  std::string part;
  while (std::getline(in, part, sep)) parts.push_back(part);
  if (!text.empty() && text.back() == sep) parts.emplace_back();
  return parts;
}

double unit_scale(const std::string& unit, const std::string& flag,
                  const std::vector<std::pair<std::string, double>>& table) {
  std::string known;
  for (const auto& [name, scale] : table) {
    if (name == unit) return scale;
    known += (known.empty() ? "" : ", ") + name;
  }
  throw InputError(flag, "unknown unit '" + unit + "' (expected one of: " + known + ")");
}

}  // namespace

std::vector<double> parse_number_list(const std::string& text, const std::string& flag) {
  std::vector<double> out;
  for (const std::string& item : split(text, ',')) {
    char* end = nullptr;
    const double value = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || !std::isfinite(value)) {
      throw InputError(flag, "expected a comma-separated list of numbers, got '" + text + "'");
    }
    out.push_back(value);
  }
  if (out.empty()) {
    throw InputError(flag, "expected a comma-separated list of numbers, got '" + text + "'");
  }
  return out;
}

std::string shell_quoted(const std::string& text) {
  std::string out = "'";
  for (char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

int run_python_script(const std::string& python, const char* script, const std::string& tag,
                      const std::vector<std::string>& args) {
  // Created exclusively, never through a link planted in the shared temporary folder.
  const std::string base =
      (std::filesystem::temp_directory_path() / ("hapvox_" + tag + "_" + std::to_string(getpid())))
          .string();
  engine::io::OutputFile file(base, ".py");
  const std::filesystem::path path = file.partial_path();
  file.write(script, std::strlen(script));
  std::string command = shell_quoted(python) + " " + shell_quoted(path.string());
  for (const std::string& arg : args) command += " " + shell_quoted(arg);
  std::fflush(stdout);  // what we printed comes before what python prints
  const int status = std::system(command.c_str());
  file.discard();
  if (status == 0) return 0;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

Eigen::Vector3d parse_vec3(const std::string& text, const std::string& flag) {
  const auto parts = split(text, ',');
  if (parts.size() != 3) throw InputError(flag, "expected X,Y,Z, got '" + text + "'");
  return {parse_number(parts[0], flag), parse_number(parts[1], flag), parse_number(parts[2], flag)};
}

void MappingFlags::add_to(CLI::App& app) {
  auto* t = app.add_option("--threshold", threshold,
                           "Intensity at or above which a voxel is material (density 1)");
  auto* w = app.add_option("--window", window,
                           "LO,HI: intensities map linearly to density 0..1 (default: a "
                           "threshold at Otsu's value)");
  t->excludes(w);
}

engine::IntensityMapping MappingFlags::resolve() const {
  if (!threshold.empty()) {
    return engine::io::threshold_mapping(parse_number(threshold, "--threshold"));
  }
  if (!window.empty()) {
    const auto parts = split(window, ',');
    if (parts.size() != 2) throw InputError("--window", "expected LO,HI, got '" + window + "'");
    return engine::io::window_mapping(parse_number(parts[0], "--window"),
                                      parse_number(parts[1], "--window"));
  }
  return {};
}

void TraceFlags::add_to(CLI::App& app) {
  app.add_option("--time-col", time_col, "Name of the trace's time column")->capture_default_str();
  app.add_option("--pos-cols", pos_cols, "Names of the X,Y,Z position columns")
      ->capture_default_str();
  app.add_option("--orientation-cols", orientation_cols,
                 "Names of the W,X,Y,Z columns of the stylus orientation (a quaternion), kept "
                 "in the session as /device_orientation");
  app.add_option("--time-unit", time_unit, "Unit of the time column: s, ms, us")
      ->capture_default_str();
  app.add_option("--pos-unit", pos_unit, "Unit of the position columns: mm, cm, m, um")
      ->capture_default_str();
  app.add_option("--rate-hz", rate_hz, "Force loop rate the trace is resampled to")
      ->capture_default_str();
  app.add_option("--max-gap-s", max_gap_s,
                 "A step between trace samples longer than this is a gap: the tool holds")
      ->capture_default_str();
}

haptics::TraceColumns TraceFlags::columns() const {
  haptics::TraceColumns columns;
  columns.time = time_col;
  const auto names = split(pos_cols, ',');
  if (names.size() != 3 || names[0].empty() || names[1].empty() || names[2].empty()) {
    throw InputError("--pos-cols", "expected three column names X,Y,Z, got '" + pos_cols + "'");
  }
  columns.position = {names[0], names[1], names[2]};
  if (!orientation_cols.empty()) {
    const auto turn = split(orientation_cols, ',');
    if (turn.size() != 4 || turn[0].empty() || turn[1].empty() || turn[2].empty() ||
        turn[3].empty()) {
      throw InputError("--orientation-cols",
                       "expected four column names W,X,Y,Z, got '" + orientation_cols + "'");
    }
    columns.orientation = {turn[0], turn[1], turn[2], turn[3]};
  }
  columns.seconds_per_time_unit =
      unit_scale(time_unit, "--time-unit", {{"s", 1.0}, {"ms", 1e-3}, {"us", 1e-6}});
  columns.mm_per_position_unit =
      unit_scale(pos_unit, "--pos-unit", {{"mm", 1.0}, {"cm", 10.0}, {"m", 1000.0}, {"um", 1e-3}});
  if (!(rate_hz > 0.0) || rate_hz > 100e3) {
    throw InputError("--rate-hz", "must be in (0, 100000]");
  }
  if (!(max_gap_s > 0.0)) throw InputError("--max-gap-s", "must be positive");
  return columns;
}

void TransformFlags::add_to(CLI::App& app) {
  app.add_option("--scale", scale, "Device-to-volume scale (volume mm per device mm)")
      ->capture_default_str();
  app.add_option("--rotate-deg", rotate_deg, "Device-to-volume rotation, Euler X,Y,Z degrees");
  app.add_option("--offset-mm", offset_mm, "Device-to-volume offset X,Y,Z in mm");
  app.add_flag("--fit", fit, "Fit the trace's bounding box into the volume (uniform scale)");
}

haptics::DeviceTransform TransformFlags::resolve(const haptics::Trace& trace,
                                                 const engine::DensityField& field) const {
  if (fit) {
    if (scale != 1.0 || !rotate_deg.empty() || !offset_mm.empty()) {
      throw InputError("--fit", "cannot be combined with --scale, --rotate-deg or --offset-mm");
    }
    return haptics::fit_trace_into_box(trace, field.world_min_mm(), field.world_max_mm());
  }
  return resolve_fixed();
}

haptics::DeviceTransform TransformFlags::resolve_fixed() const {
  if (!std::isfinite(scale) || scale <= 0.0) throw InputError("--scale", "must be positive");
  haptics::DeviceTransform transform;
  transform.scale = scale;
  if (!rotate_deg.empty()) {
    transform.rotation = haptics::rotation_from_euler_deg(parse_vec3(rotate_deg, "--rotate-deg"));
  }
  if (!offset_mm.empty()) transform.offset_mm = parse_vec3(offset_mm, "--offset-mm");
  return transform;
}

engine::ToolForceOptions ForceFlags::resolve() const {
  engine::ToolForceOptions options = this->options;
  options.contact_law =
      contact_law == "paper" ? engine::ContactLaw::kPaper : engine::ContactLaw::kHertz;
  const double reference = options.reference_length_mm;
  if (!std::isfinite(reference) || reference < 0.0) {
    throw InputError("--reference-length-mm", "must be positive, or 0 for the tool radius");
  }
  if (reference > 0.0 && options.contact_law != engine::ContactLaw::kPaper) {
    throw InputError("--reference-length-mm",
                     "needs --contact-law paper (the Hertz law measures L from the contact)");
  }
  const double surface = options.surface_density;
  if (!(surface > 0.0 && surface <= 1.0)) {
    throw InputError("--surface-density", "must lie in (0, 1]");
  }
  if (!(options.friction_coefficient >= 0.0)) {
    throw InputError("--friction", "must be zero or positive (inf: the contact never slips)");
  }
  return options;
}

void ForceFlags::add_to(CLI::App& app) {
  app.add_option("--youngs-modulus-pa,-E", options.material.youngs_modulus_pa,
                 "Young's modulus E of the material, Pa")
      ->capture_default_str();
  app.add_option("--poisson", options.material.poisson_ratio, "Poisson's ratio, in (-1, 0.5)")
      ->capture_default_str();
  app.add_option("--tool-diameter-mm", options.tool.diameter_mm, "Spherical tool diameter, mm")
      ->capture_default_str();
  app.add_option("--contact-law", contact_law,
                 "hertz: L from the contact, Hertz at small indentation; paper: the seed's "
                 "fixed L (docs/physics.md)")
      ->check(CLI::IsMember({"hertz", "paper"}))
      ->capture_default_str();
  app.add_option("--reference-length-mm", options.reference_length_mm,
                 "Paper law: reference length L of the strain |u|/L (0: the tool radius)")
      ->capture_default_str();
  app.add_option_function<double>(
      "--surface-density",
      [this](double value) {
        options.surface_density = value;
        surface_density_given = true;
      },
      "Density of the material's nominal surface, where contact starts, in (0, 1] "
      "(default 0.5; half the normal density when sculpting)");
  CLI::Option* friction =
      app.add_option("--friction", options.friction_coefficient,
                     "Coulomb friction coefficient mu: the tangential force is at most mu x the "
                     "normal force (inf: the contact never slips; docs/physics.md)")
          ->capture_default_str();
  // The old name: its ratio bounded the force's angle, tan = |F_t| / |F_n|, which is mu.
  app.add_option("--slip-ratio", options.friction_coefficient,
                 "Old name of --friction (the same coefficient)")
      ->excludes(friction);
}

namespace {
std::string& command_line_storage() {
  static std::string text;
  return text;
}
}  // namespace

void set_command_line(int argc, char** argv) {
  std::string& text = command_line_storage();
  text.clear();
  for (int i = 0; i < argc; ++i) text += (i ? " " : "") + std::string(argv[i]);
}

const std::string& command_line() { return command_line_storage(); }

void check_output_path(const std::string& output, const std::string& flag) {
  namespace fs = std::filesystem;
  if (output.empty()) throw InputError(flag, "an output path is required");
  engine::io::check_name_lengths(output);
  std::error_code ec;
  const fs::path parent = fs::path(output).parent_path();
  if (!parent.empty() && !fs::is_directory(parent, ec)) {
    throw InputError(output, "output directory " + parent.string() + " does not exist");
  }
  if (fs::is_directory(output, ec)) {
    throw InputError(output, "is a directory, expected a file name");
  }
}

namespace {

namespace fs = std::filesystem;

// The same file: one inode (hard or symbolic links, `./x` and `x`) when both exist, else the
// same path once symbolic links and `.`/`..` are resolved.
bool same_file(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  if (fs::equivalent(a, b, ec)) return true;
  const auto resolved = [](const fs::path& p) {
    std::error_code error;
    const fs::path absolute = fs::absolute(p, error);
    const fs::path canonical = fs::weakly_canonical(error ? p : absolute, error);
    return (error ? absolute : canonical).lexically_normal();
  };
  return resolved(a) == resolved(b);
}

// Why writing `output` would replace the existing file `input` ("" when it names it), or
// nothing when it would not.
std::optional<std::string> overwrite_reason(const OutputPath& output, const fs::path& input) {
  const fs::path path(output.path);
  if (same_file(path, input)) return "";
  if (output.files_in_dir.empty()) {
    if (same_file(output.path + ".partial", input)) {
      return " (written first as " + output.path + ".partial)";
    }
    return std::nullopt;
  }
  const bool in_dir = same_file(path, input.has_parent_path() ? input.parent_path() : ".");
  std::string name = input.filename().string();
  if (name.ends_with(".partial")) name.resize(name.size() - 8);
  if (in_dir && std::regex_match(name, std::regex(output.files_in_dir))) {
    return " (a file it writes into " + output.path + ")";
  }
  return std::nullopt;
}

}  // namespace

std::string volume_help() {
  return "Volume file (" + engine::io::volume_extensions_text(", ", ", ") +
         "; a .raw file as FILE.raw:dims=NXxNYxNZ,type=T[,endian=big,spacing_mm=SXxSYxSZ,...])"
         ", folder of DICOM slices, or generator (" +
         engine::io::generator_names_text() + ")";
}

std::vector<InputPath> volume_inputs(const std::string& spec) {
  std::vector<InputPath> inputs;
  if (spec.empty()) return inputs;
  const engine::io::VolumeFormat* format = engine::io::find_volume_format(spec);
  // A raw file's spec ("ct.raw:dims=...") is no file; the file it names is.
  std::error_code ec;
  const bool file = fs::exists(spec, ec);
  if (!file && (format == nullptr || !format->takes_options)) return inputs;
  if (file) inputs.push_back({spec, "volume"});
  if (format != nullptr) {
    try {
      const std::string data = engine::io::companion_input(*format, spec);
      if (!data.empty()) inputs.push_back({data, "volume data file"});
    } catch (const InputError&) {
      // A bad header is reported, better, when the volume is read.
    }
  }
  return inputs;
}

std::vector<InputPath> transfer_inputs(const std::string& spec) {
  const auto presets = render::TransferFunction::preset_names();
  if (spec.empty() || spec == "auto" ||
      std::find(presets.begin(), presets.end(), spec) != presets.end()) {
    return {};
  }
  return {{spec, "transfer function"}};
}

void check_outputs_spare_inputs(const std::vector<OutputPath>& outputs,
                                const std::vector<InputPath>& inputs) {
  for (const OutputPath& output : outputs) {
    if (!output.path.empty()) engine::io::check_name_lengths(output.path);
  }
  // One command's outputs, each against the others: the last written would replace the rest.
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    for (std::size_t j = i + 1; j < outputs.size(); ++j) {
      const OutputPath& a = outputs[i];
      const OutputPath& b = outputs[j];
      if (a.path.empty() || b.path.empty()) continue;
      const auto why =
          overwrite_reason(a, b.path) ? overwrite_reason(a, b.path) : overwrite_reason(b, a.path);
      if (why) {
        throw InputError(b.path, b.flag + " and " + a.flag + " name the same file" + *why);
      }
    }
  }
  for (const InputPath& input : inputs) {
    std::error_code ec;
    if (input.path.empty() || !fs::exists(input.path, ec)) continue;  // nothing to lose
    for (const OutputPath& output : outputs) {
      if (output.path.empty()) continue;
      if (const auto why = overwrite_reason(output, input.path)) {
        throw InputError(output.path, output.flag + " would overwrite the input " + input.what +
                                          " " + input.path + *why);
      }
    }
  }
  // Then each file as a place to write: no link, no special file, no other run's .partial
  // (in a folder still to be made, such as a sweep's, nothing is there yet).
  for (const OutputPath& output : outputs) {
    if (output.path.empty() || !output.files_in_dir.empty()) continue;
    const fs::path parent = fs::path(output.path).parent_path();
    std::error_code ec;
    if (parent.empty() || fs::is_directory(parent, ec))
      engine::io::check_output_target(output.path);
  }
}

}  // namespace hapvox::cli
