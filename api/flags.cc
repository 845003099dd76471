#include <CLI/CLI.hpp>
#include <algorithm>
#include <charconv>
#include <cstdio>

#include "api/internal.h"
#include "engine/errors.h"
#include "tools/cli.h"

namespace hapvox::api {

std::string flag_number(double value) {
  // The shortest text that reads back as `value`: exact, and an error line quoting it shows
  // 0.7 where the caller wrote 0.7.
  char text[40];
  const auto [end, ec] = std::to_chars(text, text + sizeof text, value);
  return std::string(text, ec == std::errc() ? end : text);
}

namespace {

void add_number(std::vector<std::string>& args, const char* flag,
                const std::optional<double>& value) {
  if (value) args.insert(args.end(), {flag, flag_number(*value)});
}

void add_text(std::vector<std::string>& args, const char* flag, const std::string& value) {
  if (!value.empty()) args.insert(args.end(), {flag, value});
}

}  // namespace

std::vector<std::string> model_flags(const ModelOptions& options) {
  std::vector<std::string> args;
  add_text(args, "--model", options.model);
  add_number(args, "--youngs-modulus-pa", options.youngs_modulus_pa);
  add_number(args, "--poisson", options.poisson_ratio);
  add_number(args, "--tool-diameter-mm", options.tool_diameter_mm);
  add_text(args, "--contact-law", options.contact_law);
  if (options.plastic) args.emplace_back("--plastic");
  add_number(args, "--yield-stress-pa", options.yield_stress_pa);
  add_text(args, "--materials", options.materials);
  add_text(args, "--labels", options.labels);
  args.insert(args.end(), options.flags.begin(), options.flags.end());
  return args;
}

std::vector<std::string> intensity_flags(const IntensityOptions& options) {
  std::vector<std::string> args;
  add_number(args, "--threshold", options.threshold);
  if (options.window) {
    args.insert(args.end(), {"--window", flag_number((*options.window)[0]) + "," +
                                             flag_number((*options.window)[1])});
  }
  return args;
}

std::unique_ptr<CLI::App> parse_replay_flags(const std::vector<std::string>& args,
                                             cli::ReplayFlags& flags) {
  auto app = std::make_unique<CLI::App>("hapvox");
  app->require_subcommand(1);
  cli::add_replay_subcommand(*app, &flags);
  cli::check_numeric_options(*app);
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 pops from the back
  try {
    app->parse(reversed);
  } catch (const CLI::ParseError& e) {
    throw InputError("hapvox replay", e.what());
  }
  return app;
}

haptics::ResampleOptions loop_clock(double rate_hz, double max_gap_s) {
  cli::TraceFlags flags;
  flags.rate_hz = rate_hz;
  flags.max_gap_s = max_gap_s;
  (void)flags.columns();
  haptics::ResampleOptions options;
  options.rate_hz = rate_hz;
  options.max_gap_s = max_gap_s;
  return options;
}

std::unique_ptr<CLI::App> parse_model_flags(const Volume& volume, const ModelOptions& options,
                                            cli::ReplayFlags& flags) {
  // The positional trace and -o only fill required slots.
  std::vector<std::string> args = {"replay", "(api)", "--volume", volume.source(), "-o", "(api)"};
  const std::vector<std::string> model = model_flags(options);
  args.insert(args.end(), model.begin(), model.end());
  return parse_replay_flags(args, flags);
}

std::string command_text(const std::vector<std::string>& args) {
  std::string text = "hapvox";
  for (const std::string& arg : args) text += " " + cli::shell_quoted(arg);
  return text;
}

haptics::DeviceTransform device_transform(const DeviceTransform& transform) {
  cli::TransformFlags flags;
  flags.scale = transform.scale;
  const auto& r = transform.rotate_deg;
  const auto& o = transform.offset_mm;
  if (r[0] != 0.0 || r[1] != 0.0 || r[2] != 0.0) {
    flags.rotate_deg = flag_number(r[0]) + "," + flag_number(r[1]) + "," + flag_number(r[2]);
  }
  if (o[0] != 0.0 || o[1] != 0.0 || o[2] != 0.0) {
    flags.offset_mm = flag_number(o[0]) + "," + flag_number(o[1]) + "," + flag_number(o[2]);
  }
  return flags.resolve_fixed();
}

}  // namespace hapvox::api
