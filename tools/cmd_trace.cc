// hapvox trace make SHAPE -o FILE: synthetic probe traces.

#include <cstdio>
#include <filesystem>

#include "engine/errors.h"
#include "tools/cli.h"

namespace hapvox::cli {
namespace {

struct TraceMakeFlags {
  std::string shape;
  std::string output;
  std::string start = "0,0,0";
  std::string direction = "0,0,-1";
  std::string lateral = "1,0,0";
  haptics::TraceMakeOptions options;
};

void run_trace_make(const TraceMakeFlags& f) {
  haptics::TraceMakeOptions options = f.options;
  options.shape = haptics::parse_trace_shape(f.shape, "trace make");
  options.start_mm = parse_vec3(f.start, "--start-mm");
  options.direction = parse_vec3(f.direction, "--direction");
  options.lateral = parse_vec3(f.lateral, "--lateral");
  check_output_path(f.output, "--output");
  const std::string ext = std::filesystem::path(f.output).extension().string();
  if (ext != ".csv" && ext != ".h5" && ext != ".hdf5") {
    throw InputError(f.output, "unknown trace format '" + ext + "' (expected .csv or .h5)");
  }
  const haptics::Trace trace = haptics::make_trace(options);
  if (ext == ".csv") {
    haptics::write_csv_trace(trace, f.output);
  } else {
    haptics::write_h5_trace(trace, f.output);
  }
  std::printf("wrote %s: %s, %zu samples over %.3f s\n", f.output.c_str(), f.shape.c_str(),
              trace.time_s.size(), trace.time_s.back() - trace.time_s.front());
}

}  // namespace

void add_trace_command(CLI::App& app) {
  CLI::App* trace = app.add_subcommand("trace", "Work with probe traces");
  trace->require_subcommand(1);
  auto flags = std::make_shared<TraceMakeFlags>();
  CLI::App* make = trace->add_subcommand(
      "make", "Write a synthetic trace: press, press-release, stroke or circle (CSV or HDF5)");
  make->add_option("shape", flags->shape, "press, press-release, stroke or circle")->required();
  make->add_option("--output,-o", flags->output, "Trace file to write (.csv or .h5)")->required();
  make->add_option("--start-mm", flags->start, "Start position X,Y,Z, mm")->capture_default_str();
  make->add_option("--direction", flags->direction, "Press direction X,Y,Z")->capture_default_str();
  make->add_option("--lateral", flags->lateral, "Stroke direction X,Y,Z")->capture_default_str();
  make->add_option("--travel-mm", flags->options.travel_mm, "Distance moved along the direction")
      ->capture_default_str();
  make->add_option("--speed-mm-s", flags->options.speed_mm_s, "Tool speed")->capture_default_str();
  make->add_option("--hold-s", flags->options.hold_s, "Hold time at the bottom")
      ->capture_default_str();
  make->add_option("--length-mm", flags->options.stroke_length_mm, "Stroke length")
      ->capture_default_str();
  make->add_option("--radius-mm", flags->options.radius_mm, "Circle radius")->capture_default_str();
  make->add_option("--rate-hz", flags->options.rate_hz, "Sample rate of the written trace")
      ->capture_default_str();
  make->callback([flags] { run_trace_make(*flags); });
}

}  // namespace hapvox::cli
