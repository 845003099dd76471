// The stated range of every numeric option of every command: one table, one check.
//
// A value outside its option's range is refused while the command line is parsed, before
// anything is read or written: "--youngs-modulus-pa: must lie in (0, 1e12], not 1e170". The
// range also shows in each option's help. The bounds are physical or practical (a stiffness
// no material has, a rate no loop runs at), and tight enough that a force, a tick count or a
// byte count made from any value in range cannot overflow.
// An option added without a row here makes every command fail at start-up (std::logic_error
// naming it), so no numeric option goes unchecked.

#include <CLI/CLI.hpp>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>

#include "engine/errors.h"
#include "tools/cli.h"

namespace hapvox::cli {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// [low, high], or open at either end; `high` may be infinity only where the option's help
// gives inf a meaning.
struct OptionRange {
  double low;
  double high;
  bool low_open = false;
  bool high_open = false;
};

constexpr bool kOpen = true;

// By long name: an option of that name means the same wherever it appears.
const std::map<std::string, OptionRange>& option_ranges() {
  static const std::map<std::string, OptionRange> table = {
      // The material and the contact.
      {"--youngs-modulus-pa", {0, 1e12, kOpen}},
      {"--poisson", {-1, 0.5, kOpen, kOpen}},
      {"--tool-diameter-mm", {0, 1000, kOpen}},
      {"--reference-length-mm", {0, 1000}},
      {"--surface-density", {0, 1, kOpen}},
      {"--normal-density", {0, 1, kOpen}},
      {"--friction", {0, kInf}},    // inf: a contact that never slips (the paper's x0)
      {"--slip-ratio", {0, kInf}},  // --friction's old name
      {"--yield-stress-pa", {0, 1e12, kOpen}},
      {"--elastoplastic-modulus-pa", {0, 1e12}},
      {"--relax-tolerance", {0, 10}},
      {"--relax-voxels-per-tick", {1, 1e9}},
      {"--voxel-mm", {0.1, 2}},  // validate contact's 40 mm block: 32 M voxels at 0.1 mm  //
                                 // validate hertz: Hertz holds to d/R = 0.15
      // The device, the loop and its clock.
      {"--max-force-n", {0, 1e6, kOpen}},  // far above any device: a run that never clamps
      {"--ramp-in-s", {0, 60}},
      {"--rate-hz", {0, 100000, kOpen}},
      {"--max-gap-s", {0, 3600, kOpen}},
      {"--scale", {0, 1e6, kOpen}},
      {"--silence-timeout-s", {0, 1, kOpen}},
      {"--end-after-silence-s", {0, 86400}},
      {"--watchdog-periods", {0, 1e6, kOpen}},
      {"--watchdog-ms", {0, 1e6, kOpen}},
      {"--cpu", {-1, 1023}},
      {"--tool-speed-mm-s", {0, 1e6, kOpen}},
      // Timing budgets (check-timing).
      {"--max-p99-lateness-us", {0, 1e9, kOpen}},
      {"--max-miss-rate", {0, 1}},
      {"--min-rate-ratio", {0, 1}},
      {"--max-watchdog-rate", {0, 1}},
      {"--max-watchdog-per-min", {0, 1e9}},
      // Rendering (replay's --render-* and render's own names).
      {"--render-fps", {0, 240, kOpen}},
      {"--fps", {0, 240, kOpen}},
      {"--render-every-ticks", {1, 1e9}},
      {"--every-ticks", {1, 1e9}},
      {"--render-slices", {1, 4096}},
      {"--slices", {1, 4096}},
      {"--render-patches", {1, 512}},
      {"--patches", {1, 512}},
      {"--render-support-mm", {0, 1e4}},
      {"--support-mm", {0, 1e4}},
      {"--render-azimuth-deg", {-360, 360}},
      {"--azimuth-deg", {-360, 360}},
      {"--render-elevation-deg", {-89, 89}},  // the camera's up vector needs |elevation| < 90
      {"--elevation-deg", {-89, 89}},
      {"--turntable", {0, 3600}},
      {"--frames", {1, 10000}},
      // Labels and the proxy mesh.
      {"--pick-threshold", {0, 1, kOpen, kOpen}},
      {"--seed-tolerance", {0, 1e30}},
      {"--spacing-mm", {0, 1000, kOpen}},
      {"--boundary-levels", {0, 8}},
      {"--coupling-n-per-mm", {0, 1000, kOpen}},
      {"--candidate-margin-mm", {0, 1000}},
      {"--fem-every-ticks", {1, 100000}},
      {"--fem-rate-hz", {0, 100000, kOpen}},
      {"--fem-steps-kept-mb", {0, 1e6, kOpen}},
      // device-sim's impairments.
      {"--drop", {0, 1}},
      {"--reorder", {0, 1}},
      {"--duplicate", {0, 1}},
      {"--seed", {0, 4294967295}},
      {"--pause-at-s", {-1e6, 1e6}},  // < 0: never
      {"--pause-s", {0, 86400}},
      // Sweeps.
      {"--jobs", {0, 4096}},
      {"--max-parallel", {0, 1e6}},
      {"--rows-per-task", {0, 1e6}},
      // Input budgets (engine/input_limits.h): MB to bytes cannot overflow 64 bits.
      {"--max-input-mb", {1, 16777216}},
      {"--max-trace-rows", {1, 1e12}},
      {"--max-sweep-rows", {1, 1e9}},
      // Benchmarks.
      {"--min-time-s", {0, 3600, kOpen}},
      {"--repetitions", {1, 1000}},
      {"--size", {64, 2048}},
      {"--plastic-size", {64, 2048}},
      {"--max-relax-s", {0, 86400, kOpen}},
      {"--round-trips", {100, 1e7}},
      {"--stroke-mm", {0, 1e4, kOpen}},
      // trace make.
      {"--travel-mm", {0, 1e4, kOpen}},
      {"--speed-mm-s", {0, 1e6, kOpen}},
      {"--hold-s", {0, 86400}},
      {"--length-mm", {0, 1e4}},
      {"--radius-mm", {0, 1e4}},
  };
  return table;
}

// 100000, 0.5, 1e12, inf: as a user would type it.
std::string bound_text(double value) {
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  const double exponent = std::log10(std::abs(value));
  if (std::abs(value) >= 1e6 && exponent == std::round(exponent)) {
    return std::string(value < 0 ? "-" : "") + "1e" + std::to_string(int(exponent));
  }
  char text[32];
  std::snprintf(text, sizeof text, "%.15g", value);
  return text;
}

std::string range_text(const OptionRange& r) {
  return std::string(r.low_open ? "(" : "[") + bound_text(r.low) + ", " + bound_text(r.high) +
         (r.high_open ? ")" : "]");
}

// Throws InputError(option, ...), as a command's own checks of its flags do, so the line
// is the same from the command line, the API and a sweep manifest's row.
void check_value(const std::string& option, const OptionRange& range, double value,
                 const std::string& text) {
  if (std::isnan(value)) throw InputError(option, "must be a number, not " + text);
  if (std::isinf(value) && !std::isinf(range.high)) {
    throw InputError(option, "must be a finite number, not " + text);
  }
  const bool above_low = range.low_open ? value > range.low : value >= range.low;
  const bool below_high = range.high_open ? value < range.high : value <= range.high;
  if (!above_low || !below_high) {
    throw InputError(option, "must lie in " + range_text(range) + ", not " + text);
  }
}

CLI::Validator range_check(const std::string& option, const OptionRange& range) {
  return CLI::Validator(
      [option, range](std::string& text) -> std::string {
        char* end = nullptr;
        const double value = std::strtod(text.c_str(), &end);
        if (end == text.c_str() || *end != '\0') return {};  // CLI11's own error follows
        check_value(option, range, value, text);
        return {};
      },
      "in " + range_text(range));
}

const OptionRange& range_of(const std::string& option) {
  const auto row = option_ranges().find(option);
  if (row == option_ranges().end()) {
    throw std::logic_error("option " + option + " has no range in tools/option_ranges.cc");
  }
  return row->second;
}

bool is_numeric(const CLI::Option& option) {
  const std::string type = option.get_type_name();
  return type.find("FLOAT") != std::string::npos || type.find("INT") != std::string::npos;
}

}  // namespace

void check_numeric_options(CLI::App& app) {
  for (CLI::Option* option : app.get_options()) {
    if (option->get_positional() || !is_numeric(*option)) continue;
    option->check(range_check(option->get_name(), range_of(option->get_name())));
  }
  for (CLI::App* sub : app.get_subcommands({})) check_numeric_options(*sub);
}

void check_option_value(const std::string& option, double value) {
  char text[32];
  const auto [end, ec] = std::to_chars(text, text + sizeof text, value);
  check_value(option, range_of(option), value, std::string(text, ec == std::errc() ? end : text));
}

}  // namespace hapvox::cli
