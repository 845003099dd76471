#pragma once
// What the `hapvox bench` subcommands share: Google Benchmark set up once and read back as
// medians, integer lists, the machine description and JSON/CSV writing, the half-filled
// clay block they measure on, the Table 1 row they fill, and where the bundled data is.

#include <benchmark/benchmark.h>

#include <cmath>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "engine/density_field.h"

namespace hapvox::cli {

/// One line of the Table 1 reproduction.
struct Table1Row {
  std::string measure;  // "force", "deletion", "relaxation", "flow-visits", "settle"
  int volume = 0;       // edge length, voxels
  int diameter = 0;     // tool diameter, voxels
  std::string unit;     // "Hz", "voxels/s", "visits/s", "s"
  double ours = NAN, naive = NAN, seed = NAN;  // NAN where there is none
  std::string note;
};

/// Parses "16,32,64" (positive integers). Throws InputError(flag, ...).
std::vector<int> parse_int_list(const std::string& text, const std::string& flag);

/// Starts Google Benchmark once with these timing settings.
void init_benchmark(double min_time_s, int repetitions);

using BenchFn = std::function<void(benchmark::State&)>;
/// Runs the named benchmarks in one go; median nanoseconds per iteration by name.
std::map<std::string, double> measure(const std::vector<std::pair<std::string, BenchFn>>& fns);
/// The same for benchmarks that time themselves (State::SetIterationTime), each run for
/// `iterations` iterations per repetition.
std::map<std::string, double> measure_manual_time(
    const std::vector<std::pair<std::string, BenchFn>>& fns, int iterations);

/// The machine a bench ran on (CPU, cores, memory, kernel, compiler, build type, library
/// versions, date), as key-value pairs for the CSV and JSON outputs.
std::vector<std::pair<std::string, std::string>> machine_description();
/// The description as a JSON object ({"cpu": ..., ...}) and as CSV comment lines
/// ("# cpu: ...\n" each).
std::string machine_json(const std::vector<std::pair<std::string, std::string>>& machine);
std::string machine_csv_comments(const std::vector<std::pair<std::string, std::string>>& machine);

/// `text` as a JSON string literal (quotes and backslashes escaped, control characters
/// dropped).
std::string json_string(const std::string& text);
/// `v` as a JSON number; null when it is not finite.
std::string json_number(double v);
/// Writes PATH.partial, then renames: a failed run leaves no half-written file. Throws
/// InputError(path, "cannot write").
void write_atomically(const std::string& path, const std::string& text);

/// A clay block filling the lower half of an n^3 volume of 1 mm voxels, stored as dense
/// leaves as a loaded scan would be.
engine::DensityField make_half_block(int n);

/// A bundled file named relative to the repository ("data/...", "traces/..."), found
/// wherever hapvox runs from: as given when it exists from the current directory; else in
/// the repository the executable was built in (build/tools/hapvox -> ../../, through
/// /proc/self/exe), the installed share directory beside the executable (../share/hapvox),
/// the source directory compiled in, and the install prefix's share directory. Anything
/// else (absolute paths, generators, other names) is returned unchanged, as is a bundled
/// name found nowhere (loading it then fails naming it).
std::string find_bundled(const std::string& path);

struct PlasticBenchFlags {
  int size = 512;
  std::string diameters = "16,32,64";
  double min_time_s = 0.2;
  int repetitions = 3;
  double max_relax_s = 30.0;
};

/// `hapvox bench plastic`: deletion rates by diameter, then relaxation after a press
/// (relaxed voxels/s and flow-to-room visits/s, settle time). Prints its tables.
std::vector<Table1Row> run_bench_plastic(const PlasticBenchFlags& f);

}  // namespace hapvox::cli
