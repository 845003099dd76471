// hapvox bench plastic: plastic deletion rates for tool diameters 16/32/64 beside a naive
// baseline in the same run and the seed, then relaxation after a press: voxels relaxed per
// second (the seed's measure) and flow-to-room visits per second, in separate columns.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>

#include "engine/errors.h"
#include "engine/relax.h"
#include "haptics/replay.h"
#include "tools/bench.h"

namespace hapvox::cli {
namespace {

// The seed's deletion, voxel by voxel through tree-level reads and writes (no cached
// accessor, no ordering, the whole bounding cube tested): the baseline for
// MassGrid::apply_deletion, doing the same partial-volume work (1 mm voxels, normal
// density 1): a voxel covered by a fraction f keeps at most (1 - f), the rest moves ahead.
std::size_t naive_deletion(openvdb::Int32Grid& grid, const Eigen::Vector3d& c,
                           const Eigen::Vector3d& dir, double radius) {
  auto& tree = grid.tree();
  auto coverage = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d r = p - c;
    const double dist = r.norm();
    const double width = dist > 0.0 ? r.cwiseAbs().sum() / dist : 1.0;
    return std::clamp((radius - dist) / width + 0.5, 0.0, 1.0);
  };
  std::size_t emptied = 0;
  const int r = static_cast<int>(std::ceil(radius)) + 2;
  for (int i = -r; i <= r; ++i) {
    for (int j = -r; j <= r; ++j) {
      for (int k = -r; k <= r; ++k) {
        const openvdb::Coord v(static_cast<int>(std::floor(c.x())) + i,
                               static_cast<int>(std::floor(c.y())) + j,
                               static_cast<int>(std::floor(c.z())) + k);
        const Eigen::Vector3d p(v.x(), v.y(), v.z());
        const double covered = coverage(p);
        if (covered <= 0.0) continue;
        const std::int32_t units = tree.getValue(v);
        const auto room =
            static_cast<std::int32_t>(std::floor(engine::kNormalDensityUnits * (1.0 - covered)));
        if (units <= room) continue;
        Eigen::Vector3d q = p;
        openvdb::Coord target = v;
        do {
          q += 0.5 * dir;
          target = openvdb::Coord(static_cast<int>(std::lround(q.x())),
                                  static_cast<int>(std::lround(q.y())),
                                  static_cast<int>(std::lround(q.z())));
        } while (coverage(Eigen::Vector3d(target.x(), target.y(), target.z())) > 0.0);
        tree.setValueOn(target, tree.getValue(target) + units - room);
        if (room > 0) {
          tree.setValueOn(v, room);
        } else {
          tree.setValueOff(v, 0);
        }
        ++emptied;
      }
    }
  }
  return emptied;
}

}  // namespace

std::vector<Table1Row> run_bench_plastic(const PlasticBenchFlags& f) {
  std::vector<Table1Row> table;
  const std::vector<int> diameters = parse_int_list(f.diameters, "--diameters");
  if (f.size < 64) throw InputError("--size", "must be at least 64");
  if (!(f.min_time_s > 0.0)) throw InputError("--min-time-s", "must be positive");
  if (f.repetitions < 1) throw InputError("--repetitions", "must be at least 1");
  init_benchmark(f.min_time_s, f.repetitions);
  const int n = f.size;
  const engine::DensityField field = make_half_block(n);
  const double face = 0.5 * n - 0.5;
  std::printf(
      "plastic deletion and relaxation, %d^3 clay block (half full), 1 mm voxels, one core\n", n);
  std::printf(
      "deletion: one surface change per iteration, the tool ploughing 0.05 mm per event\n\n");
  // "all": MassGrid::apply_deletion testing every voxel of the sweep in index order, as
  // before issue 29 (the same clay, bit for bit); "ours" visits only the active voxels of the
  // leaves the sweep reaches, less the last sweep's core (RelaxOptions::skip_swept_voxels).
  std::printf("%9s %12s %12s %12s %10s %9s %10s %9s\n", "diameter", "ours Hz", "all Hz", "naive Hz",
              "ours/naive", "ours/all", "seed Hz", "ours/seed");
  const std::map<int, double> seed_deletion_hz = {{16, 2000}, {32, 250}, {64, 24}};
  for (int d : diameters) {
    const double radius = 0.5 * d;
    // The tool's centre at each event: 0.05 mm steps along x, a quarter of its diameter in
    // the face, and a fresh lane (d + 4 mm further along y, from the block's middle) each
    // time it reaches the far end, so a long measurement never ploughs air or its own
    // groove (10,000 events, 0.2 s at 50 kHz, plough 500 mm: past a 512 mm block's end).
    const double lane_mm = std::max(n - d - 4.0, 1.0);
    const long events_a_lane = std::max(1L, static_cast<long>(lane_mm / 0.05));
    const long lanes = std::max(1L, static_cast<long>(lane_mm / (d + 4.0)) + 1);
    auto centre_at = [=](long event) {
      const long lane = (event / events_a_lane + lanes / 2) % lanes;
      return Eigen::Vector3d(radius + 2.0 + 0.05 * static_cast<double>(event % events_a_lane),
                             radius + 2.0 + static_cast<double>(lane) * (d + 4.0),
                             face + radius - 0.25 * d);
    };
    // Each benchmark ploughs its own copy so all see the same material.
    auto ploughing = [&](bool skip_swept_voxels) {
      return [&, skip_swept_voxels](benchmark::State& st) {
        engine::RelaxOptions options;
        options.skip_swept_voxels = skip_swept_voxels;
        engine::MassGrid mass(field, options);
        engine::SurfaceChange change;
        change.direction = Eigen::Vector3d(0.0, 0.0, -1.0);
        change.radius_mm = radius;
        std::vector<openvdb::Coord> changes;
        long event = 0;
        for (auto _ : st) {
          change.from_mm = change.position_mm = centre_at(event++);
          benchmark::DoNotOptimize(mass.apply_deletion(change));
          mass.take_changes(changes);  // as the publisher does; the naive side keeps no list
        }
      };
    };
    auto naive = [&](benchmark::State& st) {
      engine::MassGrid mass(field);
      openvdb::Int32Grid::Ptr grid = mass.grid().deepCopy();
      long event = 0;
      for (auto _ : st) {
        benchmark::DoNotOptimize(
            naive_deletion(*grid, centre_at(event++), Eigen::Vector3d(0, 0, -1), radius));
      }
    };
    auto median_ns =
        measure({{"ours", ploughing(true)}, {"all", ploughing(false)}, {"naive", naive}});
    const double ours_hz = 1e9 / median_ns["ours"];
    const double all_hz = 1e9 / median_ns["all"];
    const double naive_hz = 1e9 / median_ns["naive"];
    const double seed = seed_deletion_hz.count(d) ? seed_deletion_hz.at(d) : NAN;
    char note[96];
    std::snprintf(note, sizeof note, "every voxel of the sweep tested: %.0f Hz", all_hz);
    table.push_back({"deletion", n, d, "Hz", ours_hz, naive_hz, seed, note});
    std::printf("%9d %12.0f %12.0f %12.0f %9.1fx %8.1fx %10.0f %8.1fx\n", d, ours_hz, all_hz,
                naive_hz, ours_hz / naive_hz, ours_hz / all_hz, seed, ours_hz / seed);
    std::fflush(stdout);
  }

  // Relaxation: a diameter-32 press (the tool sunk 8 mm, deleted at once), then relax
  // until settled, timed on the wall clock; our flow to room beside the paper's diffusion.
  // Two rates, never summed: voxels relaxed (the paper's measure, compared with the seed's
  // 217,000 voxels/s) and voxels the flow-to-room search visited (ours only).
  std::printf(
      "\nrelaxation after a diameter-32 press 8 mm deep, until no voxel exceeds 1.02 "
      "(seed: 217,000 voxels relaxed/s)\n");
  std::printf("%-16s %9s %12s %12s %12s %14s %14s %10s %12s %9s\n", "rule", "settled", "settle s",
              "relaxed", "flow visits", "relaxed/s", "visits/s", "mass", "seed vox/s", "ours/seed");
  const std::int64_t mass_before = engine::MassGrid(field).summed_mass_units();
  Table1Row relax_row{"relaxation", n, 32, "voxels/s", NAN, NAN, 217000.0, "voxels relaxed"};
  Table1Row visits_row{
      "flow-visits", n,   32,  "visits/s",
      NAN,           NAN, NAN, "flow-to-room search visits (ours only; not relaxed voxels)"};
  Table1Row settle_row{"settle", n, 32, "s", NAN, NAN, NAN, ""};
  std::string notes;
  for (const engine::RelaxRule rule :
       {engine::RelaxRule::kFlowToRoom, engine::RelaxRule::kPaperDiffusion}) {
    const bool ours = rule == engine::RelaxRule::kFlowToRoom;
    // Ours settles in milliseconds: the median of several presses. The paper's rule runs
    // once, until it settles or --max-relax-s.
    const int runs = ours ? std::max(3, f.repetitions) : 1;
    std::vector<double> settle_s, relaxed_rate, visit_rate;
    bool all_settled = true, exact = true;
    std::size_t relaxed = 0, visits = 0;
    for (int run = 0; run < runs; ++run) {
      engine::RelaxOptions options;
      options.rule = rule;
      engine::MassGrid mass(field, options);
      engine::SurfaceChange press;
      press.direction = Eigen::Vector3d(0, 0, -1);
      press.radius_mm = 16.0;
      press.from_mm = Eigen::Vector3d(0.5 * n, 0.5 * n, face + 16.0);
      press.position_mm = Eigen::Vector3d(0.5 * n, 0.5 * n, face + 16.0 - 8.0);
      using Clock = std::chrono::steady_clock;
      mass.apply_deletion(press);
      const auto t1 = Clock::now();
      std::vector<openvdb::Coord> changes;  // drained as a publisher would
      const auto give_up = t1 + std::chrono::duration<double>(f.max_relax_s);
      while (!mass.settled() && Clock::now() < give_up) {
        mass.relax(100000);
        mass.take_changes(changes);
      }
      const double seconds = std::chrono::duration<double>(Clock::now() - t1).count();
      all_settled = all_settled && mass.settled();
      exact = exact && mass.summed_mass_units() == mass_before;
      relaxed = mass.work().relaxed_voxels;
      visits = mass.work().flow_visits;
      settle_s.push_back(seconds);
      relaxed_rate.push_back(static_cast<double>(relaxed) / seconds);
      visit_rate.push_back(static_cast<double>(visits) / seconds);
    }
    const double median_s = haptics::percentile(settle_s, 50.0);
    const double median_relaxed = haptics::percentile(relaxed_rate, 50.0);
    const double median_visits = haptics::percentile(visit_rate, 50.0);
    std::printf("%-16s %9s %12.6g %12zu %12zu %14.0f %14.0f %10s %12.0f %8.3gx\n",
                ours ? "ours (flow)" : "paper (diffuse)", all_settled ? "yes" : "NO", median_s,
                relaxed, visits, median_relaxed, median_visits, exact ? "exact" : "CHANGED",
                relax_row.seed, median_relaxed / relax_row.seed);
    std::fflush(stdout);
    char note[160];
    std::snprintf(note, sizeof note, "%s: %s after %.6f s", ours ? "ours" : "naive (paper rule)",
                  all_settled ? "settled" : "not settled", median_s);
    (ours ? relax_row.ours : relax_row.naive) = median_relaxed;
    if (ours) visits_row.ours = median_visits;  // the paper's rule has no flow: no naive
    (ours ? settle_row.ours : settle_row.naive) = all_settled ? median_s : INFINITY;
    notes += (notes.empty() ? "" : "; ") + std::string(note);
  }
  relax_row.note += "; " + notes;
  visits_row.note += "; " + notes;
  settle_row.note = notes;
  table.push_back(relax_row);
  table.push_back(visits_row);
  table.push_back(settle_row);
  return table;
}

}  // namespace hapvox::cli
