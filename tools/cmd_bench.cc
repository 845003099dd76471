// hapvox bench force: force-computation rates for tool diameters 16/32/64 voxels, ours
// beside a naive per-voxel-accessor baseline in the same run and the seed's Table 1.
// hapvox bench plastic (tools/cmd_bench_plastic.cc): deletion rates and relaxation.
// hapvox bench table1 (or plain `hapvox bench`, same options): both, one table with the
// seeds' figures and ratios, written as CSV and JSON with a description of the machine.
// Timing comes from Google Benchmark (repetitions, medians); this file only sets up the
// scenes and prints the table.

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>

#include "engine/errors.h"
#include "engine/io/output_file.h"
#include "engine/version.h"
#include "tools/bench.h"
#include "tools/cli.h"

namespace hapvox::cli {

void add_bench_fem_command(CLI::App& bench);     // tools/cmd_bench_fem.cc
void add_bench_bridge_command(CLI::App& bench);  // tools/cmd_bench_bridge.cc
void add_bench_sculpt_command(CLI::App& bench);  // tools/cmd_bench_sculpt.cc

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

struct TableRow {
  int size, diameter, samples;
  double ours_hz, naive_hz;
};

std::vector<Table1Row> run_bench_force(const BenchFlags& f) {
  const std::vector<int> sizes = parse_int_list(f.sizes, "--sizes");
  const std::vector<int> diameters = parse_int_list(f.diameters, "--diameters");
  if (!(f.min_time_s > 0.0)) throw InputError("--min-time-s", "must be positive");
  if (f.repetitions < 1) throw InputError("--repetitions", "must be at least 1");
  if (!f.csv.empty()) check_output_path(f.csv, "--csv");

  init_benchmark(f.min_time_s, f.repetitions);

  std::printf("force computation rate, lockstep single thread, median of %d repetitions\n",
              f.repetitions);
  std::printf("tool pressed 1/4 diameter into a half-filled block of 1 mm voxels\n\n");
  std::printf("%7s %9s %8s %12s %12s %8s %10s %9s\n", "volume", "diameter", "samples", "ours Hz",
              "naive Hz", "ours/naive", "seed Hz", "ours/seed");
  std::vector<TableRow> rows;
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
          // The same law as step's normal force, from the seed's voxel-by-voxel integral.
          const engine::ContactIntegral c = model.integrate_contact_naive(p, state);
          const Eigen::Vector3d n = c.area_vector_mm2.normalized();
          const Eigen::Vector3d force = -model.hertz_normal_force_n(c, (p - x0).dot(n)) * n;
          benchmark::DoNotOptimize(force);
          ++i;
        }
      };
      auto median_ns = measure({{"ours", ours}, {"naive", naive}});
      TableRow row{n, d, model.surface_sample_count(), 1e9 / median_ns["ours"],
                   1e9 / median_ns["naive"]};
      const double seed = seed_force_rate_hz(n, d);
      std::printf("%6d^3 %9d %8d %12.0f %12.0f %9.1fx %10.0f %8.1fx\n", n, d, row.samples,
                  row.ours_hz, row.naive_hz, row.ours_hz / row.naive_hz, seed, row.ours_hz / seed);
      std::fflush(stdout);
      rows.push_back(row);
    }
  }
  std::vector<Table1Row> table;
  for (const TableRow& row : rows) {
    table.push_back({"force", row.size, row.diameter, "Hz", row.ours_hz, row.naive_hz,
                     seed_force_rate_hz(row.size, row.diameter),
                     std::to_string(row.samples) + " surface samples"});
  }
  if (!f.csv.empty()) {
    std::ostringstream out;
    out << "volume,diameter_voxels,surface_samples,ours_hz,naive_hz,seed_hz\n";
    for (const TableRow& row : rows) {
      out << row.size << "," << row.diameter << "," << row.samples << "," << row.ours_hz << ","
          << row.naive_hz << "," << seed_force_rate_hz(row.size, row.diameter) << "\n";
    }
    engine::io::write_text_atomically(f.csv, out.str());
    std::printf("\nwrote %s\n", f.csv.c_str());
  }
  return table;
}

struct Table1Flags {
  BenchFlags force;
  PlasticBenchFlags plastic;
  std::string csv, json;
};

void run_bench_table1(Table1Flags f) {
  f.plastic.diameters = f.force.diameters;
  if (!f.csv.empty()) check_output_path(f.csv, "--csv");
  if (!f.json.empty()) check_output_path(f.json, "--json");
  f.force.csv.clear();
  f.plastic.min_time_s = f.force.min_time_s;
  f.plastic.repetitions = f.force.repetitions;
  const auto machine = machine_description();
  std::printf("Table 1 of both Prados seeds, reproduced on this machine\n");
  for (const auto& [key, value] : machine) std::printf("  %-12s %s\n", key.c_str(), value.c_str());
  std::printf("\n");
  std::vector<Table1Row> rows = run_bench_force(f.force);
  std::printf("\n");
  for (const Table1Row& row : run_bench_plastic(f.plastic)) rows.push_back(row);

  std::printf("\nsummary (medians; ratios ours/seed and ours/naive)\n");
  std::printf("%-11s %7s %9s %9s %13s %13s %13s %10s %10s\n", "measure", "volume", "diameter",
              "unit", "ours", "naive", "seed", "ours/seed", "ours/naive");
  std::ostringstream csv;
  csv << "measure,volume,diameter_voxels,unit,ours,naive,seed,ours_over_seed,ours_over_naive,"
         "note\n";
  std::ostringstream json;
  json << "{\n  \"machine\": " << machine_json(machine) << ",\n  \"rows\": [\n";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const Table1Row& r = rows[i];
    std::printf("%-11s %6d^3 %9d %9s %13.6g %13.6g %13.6g %9.3gx %9.3gx\n", r.measure.c_str(),
                r.volume, r.diameter, r.unit.c_str(), r.ours, r.naive, r.seed, r.ours / r.seed,
                r.ours / r.naive);
    csv << r.measure << "," << r.volume << "," << r.diameter << "," << r.unit << ","
        << json_number(r.ours) << "," << json_number(r.naive) << "," << json_number(r.seed) << ","
        << json_number(r.ours / r.seed) << "," << json_number(r.ours / r.naive) << ",\"" << r.note
        << "\"\n";
    json << "    {\"measure\": " << json_string(r.measure) << ", \"volume\": " << r.volume
         << ", \"diameter_voxels\": " << r.diameter << ", \"unit\": " << json_string(r.unit)
         << ", \"ours\": " << json_number(r.ours) << ", \"naive\": " << json_number(r.naive)
         << ", \"seed\": " << json_number(r.seed) << ", \"note\": " << json_string(r.note) << "}"
         << (i + 1 < rows.size() ? "," : "") << "\n";
  }
  json << "  ]\n}\n";
  if (!f.csv.empty()) {
    write_atomically(f.csv, machine_csv_comments(machine) + csv.str());
    std::printf("\nwrote %s\n", f.csv.c_str());
  }
  if (!f.json.empty()) {
    write_atomically(f.json, json.str());
    std::printf("wrote %s\n", f.json.c_str());
  }
}

// Registers table1's options on `cmd`; with `with_callback`, `cmd` runs table1.
std::shared_ptr<Table1Flags> add_table1_options(CLI::App* cmd, bool with_callback = true) {
  auto flags = std::make_shared<Table1Flags>();
  cmd->add_option("--sizes", flags->force.sizes, "Volume edge lengths for the force rates")
      ->capture_default_str();
  cmd->add_option("--diameters", flags->force.diameters, "Tool diameters, voxels")
      ->capture_default_str();
  cmd->add_option("--plastic-size", flags->plastic.size,
                  "Volume edge length for deletion and relaxation")
      ->capture_default_str();
  cmd->add_option("--min-time-s", flags->force.min_time_s, "Minimum time per measurement")
      ->capture_default_str();
  cmd->add_option("--repetitions", flags->force.repetitions, "Repetitions (the median is reported)")
      ->capture_default_str();
  cmd->add_option("--max-relax-s", flags->plastic.max_relax_s, "Give up relaxing after this long")
      ->capture_default_str();
  cmd->add_option("--csv", flags->csv, "Write the summary as CSV");
  cmd->add_option("--json", flags->json, "Write the summary and machine as JSON");
  if (with_callback) cmd->callback([flags] { run_bench_table1(*flags); });
  return flags;
}

}  // namespace

void add_bench_command(CLI::App& app) {
  CLI::App* bench = app.add_subcommand(
      "bench",
      "Benchmarks, ours beside a naive baseline; without a subcommand, what `bench table1` "
      "runs (both seeds' Table 1), with its options");
  bench->require_subcommand(0, 1);
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

  auto plastic_flags = std::make_shared<PlasticBenchFlags>();
  CLI::App* plastic = bench->add_subcommand(
      "plastic",
      "Plastic deletion rates for tool diameters 16/32/64 and relaxation voxels/s "
      "(Prados plastic paper, section 5)");
  plastic->add_option("--size", plastic_flags->size, "Volume edge length, voxels")
      ->capture_default_str();
  plastic->add_option("--diameters", plastic_flags->diameters, "Tool diameters, voxels")
      ->capture_default_str();
  plastic->add_option("--min-time-s", plastic_flags->min_time_s, "Minimum time per measurement")
      ->capture_default_str();
  plastic
      ->add_option("--repetitions", plastic_flags->repetitions,
                   "Repetitions (the median is reported)")
      ->capture_default_str();
  plastic
      ->add_option("--max-relax-s", plastic_flags->max_relax_s, "Give up relaxing after this long")
      ->capture_default_str();
  plastic->callback([plastic_flags] { run_bench_plastic(*plastic_flags); });

  // `hapvox bench table1`, and plain `hapvox bench` (issue 4: one command reproduces
  // both seeds' Table 1) with the same options and defaults.
  CLI::App* table1 = bench->add_subcommand(
      "table1",
      "Both seeds' Table 1: force rates (diameters x volumes), plastic deletion rates and "
      "relaxation voxels/s, ours beside a naive baseline and the seeds, as CSV/JSON with the "
      "machine description");
  add_table1_options(table1);
  const auto plain_flags = add_table1_options(bench, false);
  bench->callback([bench, plain_flags] {
    if (bench->get_subcommands().empty()) run_bench_table1(*plain_flags);
  });
  add_bench_fem_command(*bench);
  add_bench_bridge_command(*bench);
  add_bench_sculpt_command(*bench);
  // Checked once bench's command line is parsed, before any benchmark runs (subcommands'
  // callbacks come first): plain bench's options given before a subcommand are refused.
  bench->parse_complete_callback([bench] {
    if (bench->get_subcommands().empty()) return;
    for (const CLI::Option* option : bench->get_options()) {
      if (option->count() > 0 && option->get_name() != "--help") {
        throw InputError(option->get_name(),
                         "before a subcommand: bench's own options are table1's, for plain "
                         "`hapvox bench`; put them after the subcommand");
      }
    }
  });
}

}  // namespace hapvox::cli
