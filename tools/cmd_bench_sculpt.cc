// hapvox bench sculpt: a realtime plastic stroke through the half-filled clay block, with
// the force and relaxation threads running (haptics/realtime.h), for each tool diameter,
// and the same stroke in lockstep printed beside it as the reference. It reports what a
// sculpting user feels: the force loop's lateness and missed ticks, the surface-change
// queue's depth, the lag from a plastic event to the force thread reading a field that has
// its deletion, and what the relaxation had left when the stroke ended.

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/relax.h"
#include "engine/tool_force.h"
#include "haptics/deletion_lag.h"
#include "haptics/realtime.h"
#include "haptics/trace_device.h"
#include "haptics/voxel_model.h"
#include "tools/bench.h"
#include "tools/cli.h"

namespace hapvox::cli {
namespace {

using Clock = std::chrono::steady_clock;
using haptics::DeletionLags;
using haptics::TickTimes;

struct SculptBenchFlags {
  int size = 512;
  std::string diameters = "16,32,64";
  double speed_mm_s = 20.0;
  double stroke_mm = 40.0;
};

// The stroke: from 1 mm above the face down to a quarter of the diameter deep, then along
// x, at one speed throughout, then held still for kHoldS (the last events' deletions get
// read), sampled at 1 kHz. The block's face lies at z = n/2 - 1/2.
constexpr double kHoldS = 0.1;

haptics::ResampledTrace stroke_trace(int n, double diameter_mm, const SculptBenchFlags& f) {
  const double radius = 0.5 * diameter_mm;
  const double face = 0.5 * n - 0.5;
  const Eigen::Vector3d top(radius + 8.0, 0.5 * n + 0.37, face + radius + 1.0);
  const Eigen::Vector3d bottom = top - Eigen::Vector3d(0.0, 0.0, 1.0 + 0.25 * diameter_mm);
  const Eigen::Vector3d end = bottom + Eigen::Vector3d(f.stroke_mm, 0.0, 0.0);
  const double down_s = (top - bottom).norm() / f.speed_mm_s;
  const double along_s = f.stroke_mm / f.speed_mm_s;
  haptics::ResampledTrace trace;
  trace.rate_hz = 1000.0;
  const auto ticks =
      static_cast<std::size_t>(std::ceil((down_s + along_s + kHoldS) * trace.rate_hz)) + 1;
  for (std::size_t k = 0; k < ticks; ++k) {
    const double t = static_cast<double>(k) / trace.rate_hz;
    const double along = std::min(1.0, (t - down_s) / along_s);
    const Eigen::Vector3d p =
        t < down_s ? top + (bottom - top) * (t / down_s) : bottom + (end - bottom) * along;
    trace.time_s.push_back(t);
    trace.position_mm.push_back(p);
    trace.holding.push_back(0);
  }
  return trace;
}

// A device that records, for every tick, when it was read (the tick's start: the field it
// reads was taken up just before) and when its force was sent (after the force stage, so
// after any hand-off), with the row's plastic numbers. Preallocated: the force thread
// only stores.
class RecordingDevice final : public haptics::Device {
 public:
  explicit RecordingDevice(haptics::Device& inner)
      : inner_(inner), ticks_(inner.tick_count()), start_(Clock::now()) {}

  double rate_hz() const override { return inner_.rate_hz(); }
  std::size_t tick_count() const override { return inner_.tick_count(); }
  const haptics::DeviceTransform& transform() const override { return inner_.transform(); }
  Clock::time_point wait_for_tick(std::size_t tick, Clock::time_point deadline) override {
    return inner_.wait_for_tick(tick, deadline);
  }
  void read(std::size_t tick, haptics::DeviceReading& reading) override {
    ticks_[tick].read_ns = since_start_ns();
    inner_.read(tick, reading);
  }
  void send(std::size_t tick, const haptics::Vec3d& force_device_n, const haptics::TickRecord& row,
            bool fault) override {
    TickTimes& t = ticks_[tick];
    t.sent_ns = since_start_ns();
    t.plastic_event = row.plastic_event != 0;
    t.published_event = row.published_event;
    t.queue_depth = row.queue_depth;
    t.force_n = row.force_n.norm();
    inner_.send(tick, force_device_n, row, fault);
  }

  const std::vector<TickTimes>& ticks() const { return ticks_; }

 private:
  std::int64_t since_start_ns() const {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - start_).count();
  }
  haptics::Device& inner_;
  std::vector<TickTimes> ticks_;
  Clock::time_point start_;
};

struct StrokeResult {
  std::size_t ticks = 0;
  haptics::TimingSummary timing;  // realtime only
  haptics::SculptSummary sculpted;
  DeletionLags lags;
  double queue_p99 = 0.0;
  std::int64_t queue_max = 0;
  double peak_force_n = 0.0;
};

StrokeResult run_stroke(const engine::DensityField& field, double diameter_mm, bool realtime,
                        const SculptBenchFlags& f) {
  const int n = field.dims().x();
  engine::ToolForceOptions options;
  options.tool.diameter_mm = diameter_mm;
  options.plastic.enabled = true;
  haptics::TraceDevice trace(stroke_trace(n, diameter_mm, f), haptics::DeviceTransform{});
  RecordingDevice device(trace);
  engine::MassGrid mass(field);
  haptics::SurfaceChangeChannel channel;
  StrokeResult result;
  if (realtime) {
    haptics::DoubleBufferedField buffers(field);
    const engine::ToolForceModel model(buffers.buffer(0), options);
    haptics::RealtimeSculpt sculpt;
    sculpt.mass = &mass;
    sculpt.field = &buffers;
    sculpt.channel = &channel;
    haptics::replay_realtime(model, device, haptics::DeviceLimits{}, nullptr, {}, &sculpt,
                             &result.sculpted, &result.timing);
  } else {
    engine::DensityField mirror(field.grid().deepCopy(), field.voxel_size_mm(), field.origin_mm(),
                                field.dims(), field.direction());
    const engine::ToolForceModel model(mirror, options);
    haptics::SculptContext sculpt;
    sculpt.mass = &mass;
    sculpt.mirror = &mirror;
    sculpt.channel = &channel;
    haptics::replay_lockstep(model, device, haptics::DeviceLimits{}, nullptr, {}, &sculpt,
                             &result.sculpted);
  }
  result.ticks = device.ticks().size();
  result.lags = haptics::deletion_lags(device.ticks());
  std::vector<double> depth;
  for (const TickTimes& t : device.ticks()) {
    depth.push_back(static_cast<double>(t.queue_depth));
    result.queue_max = std::max(result.queue_max, t.queue_depth);
    result.peak_force_n = std::max(result.peak_force_n, t.force_n);
  }
  result.queue_p99 = haptics::percentile(depth, 99.0);
  return result;
}

void print_row(int d, const char* mode, const StrokeResult& r, bool realtime) {
  const DeletionLags& l = r.lags;
  char late[64] = "-", missed[64] = "-";
  if (realtime) {
    std::snprintf(late, sizeof late, "%.1f", r.timing.lateness.p99_us);
    std::snprintf(missed, sizeof missed, "%zu", r.timing.missed_deadlines);
  }
  std::printf(
      "%8d %-9s %6zu %10s %6s %7zu %6lld %6.0f %9llu %8.2f %8.2f %8.2f %6.0f %7zu %7zu "
      "%8zu %8.1f %7.3f %s\n",
      d, mode, r.ticks, late, missed, l.events, static_cast<long long>(r.queue_max), r.queue_p99,
      static_cast<unsigned long long>(r.sculpted.queue_overflows), l.p50_ms, l.p99_ms, l.max_ms,
      l.p99_ticks, l.unseen, r.sculpted.backlog_changes, r.sculpted.backlog_voxels,
      1e3 * r.sculpted.drain_s, r.peak_force_n,
      r.sculpted.initial_mass_units == r.sculpted.final_mass_units ? "exact" : "CHANGED");
  std::fflush(stdout);
}

void run_bench_sculpt(const SculptBenchFlags& f) {
  const std::vector<int> diameters = parse_int_list(f.diameters, "--diameters");
  // --size, --speed-mm-s and --stroke-mm are checked against their ranges (option_ranges.cc).
  for (int d : diameters) {
    if (d + 16.0 + f.stroke_mm > f.size) {
      char problem[160];
      std::snprintf(problem, sizeof problem,
                    "a %d mm tool's stroke of %g mm (with 8 mm margins) leaves the %d mm block", d,
                    f.stroke_mm, f.size);
      throw InputError("--stroke-mm", problem);
    }
  }
  const engine::DensityField field = make_half_block(f.size);
  std::printf(
      "realtime sculpting stroke, %d^3 clay block (half full), 1 mm voxels, %g mm/s: from 1 mm "
      "above the face to a quarter diameter deep, then %g mm along x, held 0.1 s; force and "
      "relaxation threads at 1 kHz on %ld CPUs; lockstep (one thread, unpaced) beside it as the "
      "reference\n",
      f.size, f.speed_mm_s, f.stroke_mm, sysconf(_SC_NPROCESSORS_ONLN));
  std::printf(
      "lag: from a plastic event's force sent to the first tick whose field has its "
      "deletion; backlog: what the loop left at its end, applied in drain ms\n\n");
  std::printf("%8s %-9s %6s %10s %6s %7s %6s %6s %9s %8s %8s %8s %6s %7s %7s %8s %8s %7s %s\n",
              "diameter", "mode", "ticks", "p99 lat us", "missed", "events", "q max", "q p99",
              "q full", "lag p50", "lag p99", "lag max", "lag tk", "unseen", "backlog", "relax",
              "drain ms", "peak N", "mass");
  for (int d : diameters) {
    const StrokeResult realtime = run_stroke(field, d, true, f);
    print_row(d, "realtime", realtime, true);
    const haptics::TimingSummary& t = realtime.timing;
    std::printf(
        "%8s relaxation thread busy %.0f%%, slices p50 %.2f p99 %.2f max %.2f ms, at most %zu "
        "sweeps and %zu steps in one\n",
        "", 100.0 * t.relax_busy_fraction, 1e-3 * t.relax_slice.p50_us, 1e-3 * t.relax_slice.p99_us,
        1e-3 * t.relax_slice.max_us, t.relax_slice_max_deletions, t.relax_slice_max_steps);
    print_row(d, "lockstep", run_stroke(field, d, false, f), false);
  }
}

}  // namespace

void add_bench_sculpt_command(CLI::App& bench) {
  auto flags = std::make_shared<SculptBenchFlags>();
  CLI::App* cmd = bench.add_subcommand(
      "sculpt",
      "A realtime plastic stroke through a clay block (force and relaxation threads): "
      "lateness, queue depth, deletion lag and backlog, beside the same stroke in lockstep");
  cmd->add_option("--size", flags->size, "Volume edge length, voxels")->capture_default_str();
  cmd->add_option("--diameters", flags->diameters, "Tool diameters, voxels")->capture_default_str();
  cmd->add_option("--speed-mm-s", flags->speed_mm_s, "The tool's speed")->capture_default_str();
  cmd->add_option("--stroke-mm", flags->stroke_mm, "Length of the stroke along the face")
      ->capture_default_str();
  cmd->callback([flags] { run_bench_sculpt(*flags); });
}

}  // namespace hapvox::cli
