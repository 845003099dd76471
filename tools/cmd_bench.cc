// hapvox bench force: force-computation rates for tool diameters 16/32/64 voxels, ours
// beside a naive per-voxel-accessor baseline in the same run and the seed's Table 1.
// Timing comes from Google Benchmark (repetitions, medians); this file only sets up the
// scenes and prints the table.

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "engine/errors.h"
#include "tools/cli.h"

namespace hapvox::cli {
namespace {

struct BenchFlags {
  std::string sizes = "128,256,512";
  std::string diameters = "16,32,64";
  double min_time_s = 0.2;
  int repetitions = 5;
  std::string csv;
};

// Prados et al. (2011), Table 1: force computation rates, Hz, by volume size and diameter.
double seed_force_rate_hz(int size, int diameter) {
  static const std::map<std::pair<int, int>, double> table = {
      {{128, 16}, 4654}, {{128, 32}, 566},  {{128, 64}, 74},  {{256, 16}, 4612}, {{256, 32}, 567},
      {{256, 64}, 71},   {{512, 16}, 4567}, {{512, 32}, 560}, {{512, 64}, 67}};
  const auto it = table.find({size, diameter});
  return it == table.end() ? NAN : it->second;
}

std::vector<int> parse_int_list(const std::string& text, const std::string& flag) {
  std::vector<int> values;
  std::stringstream in(text);
  std::string part;
  while (std::getline(in, part, ',')) {
    try {
      std::size_t used = 0;
      const int v = std::stoi(part, &used);
      if (used != part.size() || v <= 0) throw std::invalid_argument(part);
      values.push_back(v);
    } catch (const std::exception&) {
      throw InputError(flag, "expected positive integers separated by commas, got '" + text + "'");
    }
  }
  if (values.empty()) throw InputError(flag, "empty list");
  return values;
}

// Collects the median of each benchmark's repetitions.
class MedianCollector : public benchmark::BenchmarkReporter {
 public:
  bool ReportContext(const Context&) override { return true; }
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      if (run.run_type == Run::RT_Aggregate && run.aggregate_name == "median") {
        // Adjusted real time is per iteration, in the run's time unit (ns here).
        median_ns[run.run_name.function_name] = run.GetAdjustedRealTime();
      }
    }
  }
  std::map<std::string, double> median_ns;
};

// A clay block filling the lower half of an n^3 volume of 1 mm voxels, stored as dense
// leaves as a loaded scan would be.
engine::DensityField make_half_block(int n) {
  engine::initialize_openvdb();
  auto grid = openvdb::FloatGrid::create(0.0f);
  grid->tree().fill(openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(n - 1, n - 1, n / 2 - 1)),
                    1.0f, true);
  grid->tree().voxelizeActiveTiles();
  return engine::DensityField(grid, Eigen::Vector3d::Ones(), Eigen::Vector3d::Zero(),
                              Eigen::Vector3i::Constant(n));
}

struct Row {
  int size, diameter, samples;
  double ours_hz, naive_hz;
};

void run_bench_force(const BenchFlags& f) {
  const std::vector<int> sizes = parse_int_list(f.sizes, "--sizes");
  const std::vector<int> diameters = parse_int_list(f.diameters, "--diameters");
  if (!(f.min_time_s > 0.0)) throw InputError("--min-time-s", "must be positive");
  if (f.repetitions < 1) throw InputError("--repetitions", "must be at least 1");
  if (!f.csv.empty()) check_output_path(f.csv, "--csv");

  std::string min_time = "--benchmark_min_time=" + std::to_string(f.min_time_s);
  std::string reps = "--benchmark_repetitions=" + std::to_string(f.repetitions);
  std::vector<std::string> args = {"hapvox-bench", min_time, reps,
                                   "--benchmark_report_aggregates_only=true"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  int argc = static_cast<int>(argv.size());
  benchmark::Initialize(&argc, argv.data());

  std::printf("force computation rate, lockstep single thread, median of %d repetitions\n",
              f.repetitions);
  std::printf("tool pressed 1/4 diameter into a half-filled block of 1 mm voxels\n\n");
  std::printf("%7s %9s %8s %12s %12s %8s %10s %9s\n", "volume", "diameter", "samples", "ours Hz",
              "naive Hz", "ours/naive", "seed Hz", "ours/seed");
  std::vector<Row> rows;
  for (int n : sizes) {
    const engine::DensityField field = make_half_block(n);
    for (int d : diameters) {
      engine::ToolForceOptions options;
      options.tool.diameter_mm = d;
      const engine::ToolForceModel model(field, options);
      const double r = 0.5 * d;
      // Face between voxel layers n/2-1 and n/2 lies at z = n/2 - 0.5.
      const Eigen::Vector3d press(0.5 * n + 0.37, 0.5 * n - 0.21, 0.5 * n - 0.5 + r - 0.25 * d);
      auto ours = [&model, press](benchmark::State& st) {
        engine::ToolForceState state = model.make_state();
        model.step(press + Eigen::Vector3d(0, 0, 0.25 * model.options().tool.diameter_mm + 1),
                   state);  // a contact-free position first, as in a real approach
        int i = 0;
        for (auto _ : st) {
          // Small motions, as the tool moves ~10 um per tick.
          const Eigen::Vector3d p = press + Eigen::Vector3d(0.01 * (i & 15), 0, -0.001 * (i & 7));
          model.step(p, state);
          benchmark::DoNotOptimize(state.force_n);
          ++i;
        }
      };
      auto naive = [&model, press](benchmark::State& st) {
        engine::ToolForceState state = model.make_state();
        const Eigen::Vector3d x0 =
            press + Eigen::Vector3d(0, 0, 0.25 * model.options().tool.diameter_mm);
        int i = 0;
        for (auto _ : st) {
          const Eigen::Vector3d p = press + Eigen::Vector3d(0.01 * (i & 15), 0, -0.001 * (i & 7));
          const engine::ContactIntegral c = model.integrate_contact_naive(p, state);
          const Eigen::Vector3d force =
              engine::ToolForceModel::traction_force_n(model.stress_pa(p - x0), c);
          benchmark::DoNotOptimize(force);
          ++i;
        }
      };
      benchmark::ClearRegisteredBenchmarks();
      benchmark::RegisterBenchmark("ours", ours)->Unit(benchmark::kNanosecond)->UseRealTime();
      benchmark::RegisterBenchmark("naive", naive)->Unit(benchmark::kNanosecond)->UseRealTime();
      MedianCollector collector;
      benchmark::RunSpecifiedBenchmarks(&collector);
      Row row{n, d, model.surface_sample_count(), 1e9 / collector.median_ns["ours"],
              1e9 / collector.median_ns["naive"]};
      const double seed = seed_force_rate_hz(n, d);
      std::printf("%6d^3 %9d %8d %12.0f %12.0f %9.1fx %10.0f %8.1fx\n", n, d, row.samples,
                  row.ours_hz, row.naive_hz, row.ours_hz / row.naive_hz, seed, row.ours_hz / seed);
      std::fflush(stdout);
      rows.push_back(row);
    }
  }
  benchmark::ClearRegisteredBenchmarks();
  if (!f.csv.empty()) {
    std::ofstream out(f.csv + ".partial");
    out << "volume,diameter_voxels,surface_samples,ours_hz,naive_hz,seed_hz\n";
    for (const Row& row : rows) {
      out << row.size << "," << row.diameter << "," << row.samples << "," << row.ours_hz << ","
          << row.naive_hz << "," << seed_force_rate_hz(row.size, row.diameter) << "\n";
    }
    out.close();
    std::filesystem::rename(f.csv + ".partial", f.csv);
    std::printf("\nwrote %s\n", f.csv.c_str());
  }
}

}  // namespace

void add_bench_command(CLI::App& app) {
  CLI::App* bench = app.add_subcommand("bench", "Benchmarks, ours beside a naive baseline");
  bench->require_subcommand(1);
  auto flags = std::make_shared<BenchFlags>();
  CLI::App* force = bench->add_subcommand(
      "force", "Force-computation rate for tool diameters 16/32/64 voxels (Prados Table 1)");
  force->add_option("--sizes", flags->sizes, "Volume edge lengths, voxels")->capture_default_str();
  force->add_option("--diameters", flags->diameters, "Tool diameters, voxels")
      ->capture_default_str();
  force->add_option("--min-time-s", flags->min_time_s, "Minimum time per measurement")
      ->capture_default_str();
  force->add_option("--repetitions", flags->repetitions, "Repetitions (the median is reported)")
      ->capture_default_str();
  force->add_option("--csv", flags->csv, "Also write the table as CSV");
  force->callback([flags] { run_bench_force(*flags); });
}

}  // namespace hapvox::cli
