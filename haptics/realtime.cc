#include "haptics/realtime.h"

#include <pthread.h>
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "engine/check.h"

namespace hapvox::haptics {
namespace {

using Clock = std::chrono::steady_clock;

// Sleeping overshoots by up to the timer slack; the last stretch is spun.
constexpr auto kSpinWindow = std::chrono::microseconds(150);

void wait_until(Clock::time_point deadline) {
  const auto now = Clock::now();
  if (deadline - now > kSpinWindow) std::this_thread::sleep_until(deadline - kSpinWindow);
  while (Clock::now() < deadline) {
  }
}

std::int64_t ns_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(b - a).count();
}

double thread_cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

long involuntary_switches() {
  rusage usage{};
  getrusage(RUSAGE_THREAD, &usage);
  return usage.ru_nivcsw;
}

// Steal time of all CPUs (the "cpu" line of /proc/stat), seconds; 0 where unreadable.
double machine_steal_s() {
  std::ifstream stat("/proc/stat");
  std::string line;
  if (!std::getline(stat, line) || line.rfind("cpu ", 0) != 0) return 0.0;
  std::istringstream fields(line.substr(4));
  long long value = 0, steal = 0;
  for (int i = 0; i < 8 && fields >> value; ++i) {
    if (i == 7) steal = value;
  }
  const long ticks_per_s = sysconf(_SC_CLK_TCK);
  return ticks_per_s > 0 ? static_cast<double>(steal) / static_cast<double>(ticks_per_s) : 0.0;
}

// Counters the relaxation thread publishes for the force thread's rows.
struct RelaxCounters {
  std::atomic<std::uint64_t> deleted{0};
  std::atomic<std::uint64_t> relaxed{0};
  std::atomic<std::int64_t> mass_units{0};
};

// The relaxation thread. It works in bounded slices while there is work (queued deletions,
// voxels to relax, a flow in flight, changes to publish or to hand to the renderer) and
// sleeps in the channel's wait_for_arrival() when there is none: an idle thread costs no
// CPU and wakes on the force thread's next push (or its end), not on a timer.
void relax_loop(RealtimeSculpt& sculpt, const std::atomic<bool>& force_done,
                RelaxCounters& counters, Clock::time_point start,
                std::vector<std::int64_t>& slice_ns, std::vector<std::int64_t>& slice_start_ns,
                double& cpu_s, RelaxStageWork& max_slice_work, RenderFeed* feed) {
  const double cpu_start = thread_cpu_s();
  std::vector<openvdb::Coord> published;
  auto last_mass = Clock::now();
  bool mass_stale = false;  // work done since the last exact mass measurement
  while (true) {
    // Arrivals before force_done: a push or the end announced after these loads bumps
    // the count, so the wait below returns at once instead of sleeping through it.
    const std::uint32_t arrivals = sculpt.channel->arrivals();
    const bool finishing = force_done.load(std::memory_order_acquire);
    const auto slice_begin = Clock::now();
    const RelaxStageWork work =
        run_relax_stage(*sculpt.mass, *sculpt.channel, sculpt.max_deletions_per_slice,
                        sculpt.relax_voxels_per_slice);
    max_slice_work.deletions = std::max(max_slice_work.deletions, work.deletions);
    max_slice_work.relax_steps = std::max(max_slice_work.relax_steps, work.relax_steps);
    const std::size_t did = work.deletions + work.relax_steps;
    mass_stale = mass_stale || did > 0;
    if (sculpt.mass->has_changes()) {
      sculpt.field->publish(*sculpt.mass, force_done, feed != nullptr ? &published : nullptr);
    }
    if (feed != nullptr && (!published.empty() || !feed->voxels.drained_backlog())) {
      feed->voxels.offer(published, *sculpt.mass);
      published.clear();
    }
    counters.deleted.store(sculpt.mass->work().deleted_voxels, std::memory_order_relaxed);
    counters.relaxed.store(sculpt.mass->work().relaxed_voxels, std::memory_order_relaxed);
    // The exact mass (a pass over the whole grid) is measured every ~50 ms while the grid
    // changes, and once more when it stops: never while nothing moves.
    const bool idle = did == 0 && !sculpt.mass->has_changes() &&
                      (feed == nullptr || feed->voxels.drained_backlog());
    if (mass_stale && (idle || Clock::now() - last_mass > std::chrono::milliseconds(50))) {
      counters.mass_units.store(sculpt.mass->total_mass_units(), std::memory_order_relaxed);
      last_mass = Clock::now();
      mass_stale = false;
    }
    if (did > 0) {
      slice_start_ns.push_back(ns_between(start, slice_begin));
      slice_ns.push_back(ns_between(slice_begin, Clock::now()));
    }
    if (finishing) break;
    if (idle) {
      sculpt.channel->wait_for_arrival(arrivals);
    } else if (did == 0) {
      // Waiting on the renderer's queue or the reader's buffer switch: poll gently.
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  }
  cpu_s = thread_cpu_s() - cpu_start;
}

}  // namespace

DurationStats duration_stats(const std::vector<double>& values_us) {
  DurationStats stats;
  stats.count = values_us.size();
  if (values_us.empty()) return stats;
  stats.p50_us = percentile(values_us, 50.0);
  stats.p99_us = percentile(values_us, 99.0);
  stats.p999_us = percentile(values_us, 99.9);
  stats.max_us = *std::max_element(values_us.begin(), values_us.end());
  return stats;
}

ReplaySummary replay_realtime(const engine::ToolForceModel& model, const TraceDevice& device,
                              const DeviceLimits& limits, SessionWriter* session,
                              const ProgressFn& progress, RealtimeSculpt* sculpt,
                              SculptSummary* sculpt_summary, TimingSummary* timing,
                              const RealtimeOptions& options) {
  ReplaySummary summary;
  summary.ticks = device.tick_count();
  summary.trace_gaps = device.trace().gap_count;
  summary.trace_held_s = device.trace().held_time_s;
  if (summary.ticks == 0) return summary;
  if (sculpt != nullptr) {
    HAPVOX_CHECK(sculpt->mass != nullptr && sculpt->field != nullptr && sculpt->channel != nullptr);
    HAPVOX_CHECK(&model.field() == &sculpt->field->buffer(0));
  }
  const double t0 = device.time_s(0);
  const auto dt = std::chrono::nanoseconds(std::llround(1e9 / device.rate_hz()));
  summary.duration_s = device.time_s(summary.ticks - 1) - t0;

  // Everything the force thread touches is made here, before it starts.
  std::vector<TickRecord> rows(summary.ticks);
  std::atomic<std::size_t> rows_done{0};
  std::atomic<bool> force_done{false};
  RelaxCounters counters;
  SculptSummary sculpted;
  if (sculpt != nullptr) {
    sculpted.initial_mass_units = sculpt->mass->total_mass_units();
    counters.mass_units.store(sculpted.initial_mass_units);
  }
  engine::ToolForceState state =
      sculpt != nullptr ? model.make_state(sculpt->field->buffer(1)) : model.make_state();
  ForceRamp ramp(limits, device.rate_hz());
  std::uint64_t plastic_events = 0;
  std::size_t nonfinite_forces = 0;
  std::size_t max_queue_depth = 0;

  const ForceThreadHooks& hooks = options.hooks;
  const std::int64_t period_ns = dt.count();
  const auto watchdog_ns = static_cast<std::int64_t>(
      std::llround(std::max(0.0, options.watchdog_periods) * static_cast<double>(period_ns)));
  SchedulerReport scheduler;
  prepare_process(options.scheduler, scheduler);
  ThreadSetupCodes thread_codes;
  std::size_t watchdog_trips = 0;
  double force_cpu_s = 0.0;
  long force_switches = 0;
  std::vector<std::int64_t> relax_slice_ns, relax_slice_start_ns;
  double relax_cpu_s = 0.0;
  RelaxStageWork max_slice_work;
  const double steal_before_s = machine_steal_s();

  // The render thread's feed, made before any thread starts.
  std::unique_ptr<RenderFeed> feed;
  RenderTiming render_timing;
  if (options.render_loop) feed = std::make_unique<RenderFeed>();
  std::exception_ptr render_error;
  std::atomic<bool> render_finished{false};
  const auto start = Clock::now() + std::chrono::milliseconds(5);
  std::thread force_thread([&] {
    pthread_setname_np(pthread_self(), "hapvox-force");
    prepare_force_thread(options.scheduler, thread_codes);
    std::uint64_t deleted_before = 0, relaxed_before = 0;
    const double cpu_start = thread_cpu_s();
    const long switches_start = involuntary_switches();
    if (hooks.loop_started) hooks.loop_started();
    for (std::size_t tick = 0; tick < summary.ticks; ++tick) {
      const auto deadline = start + tick * dt;
      wait_until(deadline);
      const auto begin = Clock::now();
      if (hooks.before_tick) hooks.before_tick(tick);
      TickRecord& row = rows[tick];
      if (sculpt != nullptr) state.read_from(sculpt->field->acquire_for_reading());
      const bool nonfinite = run_force_stage(model, device, tick, limits, state, ramp,
                                             sculpt != nullptr ? sculpt->channel : nullptr, row);
      nonfinite_forces += nonfinite ? 1 : 0;
      const auto end = Clock::now();
      if (sculpt != nullptr) {
        plastic_events += row.plastic_event;
        max_queue_depth = std::max<std::size_t>(max_queue_depth, row.queue_depth);
        const std::uint64_t deleted = counters.deleted.load(std::memory_order_relaxed);
        const std::uint64_t relaxed = counters.relaxed.load(std::memory_order_relaxed);
        row.deleted_voxels = static_cast<std::int64_t>(deleted - deleted_before);
        row.relaxed_voxels = static_cast<std::int64_t>(relaxed - relaxed_before);
        deleted_before = deleted;
        relaxed_before = relaxed;
        row.total_mass_units = counters.mass_units.load(std::memory_order_relaxed);
      }
      row.scheduled_ns = ns_between(start, deadline);
      row.start_ns = ns_between(start, begin);
      row.compute_ns = ns_between(begin, end);
      if (row.start_ns + row.compute_ns > row.scheduled_ns + watchdog_ns) {
        // A stall: this tick's force is late but fresh and finite, so it is sent as
        // computed (zeroing it would be a step). From the next tick on the ramp takes the
        // force down to zero and back in, at the ramp-in's slope.
        row.watchdog = 1;
        ++watchdog_trips;
        ramp.trip();
      }
      if (feed != nullptr) {
        feed->tool.publish(RenderToolState{row.tool_position_mm, state.displacement_mm,
                                           state.in_contact, static_cast<std::int64_t>(tick)});
      }
      rows_done.store(tick + 1, std::memory_order_release);
    }
    if (hooks.loop_finished) hooks.loop_finished();
    force_cpu_s = thread_cpu_s() - cpu_start;
    force_switches = involuntary_switches() - switches_start;
    // Back to the ordinary policy before waiting on other threads: a SCHED_FIFO thread
    // spinning on yield() would starve them on its CPU.
    if (thread_codes.policy_errno == 0) {
      sched_param normal{};
      pthread_setschedparam(pthread_self(), SCHED_OTHER, &normal);
    }
    if (sculpt != nullptr) {
      // Hand over what is still pending before the relaxation thread finishes.
      // Keep announcing the front buffer: the relaxation thread may be waiting for that
      // before it can drain the queue that this flush waits for.
      while (!sculpt->channel->flush()) {
        sculpt->field->acquire_for_reading();
        std::this_thread::yield();
      }
    }
    force_done.store(true, std::memory_order_release);
    if (sculpt != nullptr) sculpt->channel->wake();  // an idle relaxation thread finishes
  });
  std::thread relax_thread;
  if (sculpt != nullptr) {
    relax_thread = std::thread([&] {
      pthread_setname_np(pthread_self(), "hapvox-relax");
      relax_loop(*sculpt, force_done, counters, start, relax_slice_ns, relax_slice_start_ns,
                 relax_cpu_s, max_slice_work, feed.get());
    });
  }
  std::thread render_thread;
  if (feed != nullptr) {
    feed->start = start;
    render_thread = std::thread([&] {
      pthread_setname_np(pthread_self(), "hapvox-render");
      // Below the force thread and off its CPU: llvmpipe fills every core it may use, and
      // the rasteriser threads it starts inherit this thread's nice value and affinity.
      setpriority(PRIO_PROCESS, 0, 10);
      const long online = sysconf(_SC_NPROCESSORS_ONLN);
      if (options.scheduler.pin_cpu && online > 1) {
        const int force_cpu =
            options.scheduler.cpu >= 0 ? options.scheduler.cpu : static_cast<int>(online - 1);
        cpu_set_t others;
        CPU_ZERO(&others);
        for (int cpu = 0; cpu < online; ++cpu) {
          if (cpu != force_cpu) CPU_SET(cpu, &others);
        }
        pthread_setaffinity_np(pthread_self(), sizeof others, &others);
      }
      // A render loop that fails (no EGL on this thread, a full disk) must not take the
      // process down from its thread: its error is rethrown once every thread is joined.
      try {
        options.render_loop(*feed, render_timing);
      } catch (...) {
        render_error = std::current_exception();
      }
      render_finished.store(true, std::memory_order_release);
    });
  }

  // This thread: the session writer.
  std::size_t written = 0;
  const std::size_t progress_every = std::max<std::size_t>(1, summary.ticks / 100);
  std::size_t next_progress = progress_every;
  while (written < summary.ticks) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const std::size_t done = rows_done.load(std::memory_order_acquire);
    for (; written < done; ++written) {
      if (session != nullptr) session->append(rows[written]);
    }
    if (progress && written >= next_progress) {
      progress(written, summary.ticks);
      next_progress = (written / progress_every + 1) * progress_every;
    }
  }
  force_thread.join();
  if (relax_thread.joinable()) relax_thread.join();
  const auto wall_end = Clock::now();
  release_process(scheduler);
  describe_thread_setup(options.scheduler, thread_codes, scheduler);

  std::vector<double> compute_us(summary.ticks), lateness_us(summary.ticks);
  std::size_t missed = 0, stalled = 0;
  for (std::size_t i = 0; i < summary.ticks; ++i) {
    const TickRecord& row = rows[i];
    compute_us[i] = 1e-3 * static_cast<double>(row.compute_ns);
    lateness_us[i] = 1e-3 * static_cast<double>(row.start_ns - row.scheduled_ns);
    if (row.start_ns + row.compute_ns > row.scheduled_ns + period_ns) ++missed;
    if (row.start_ns - row.scheduled_ns > period_ns) ++stalled;
    summary.contact_ticks += row.contact;
    summary.clamped_ticks += row.clamped;
    summary.peak_force_n = std::max(summary.peak_force_n, row.force_n.norm());
  }
  summary.contact_time_s = static_cast<double>(summary.contact_ticks) / device.rate_hz();
  summary.contact_onsets = state.contact_onsets;
  summary.nonfinite_forces = nonfinite_forces + state.nonfinite_forces;
  summary.compute_p50_us = percentile(compute_us, 50.0);
  summary.compute_p99_us = percentile(compute_us, 99.0);
  summary.compute_max_us = *std::max_element(compute_us.begin(), compute_us.end());
  if (timing != nullptr) {
    timing->rate_hz = device.rate_hz();
    timing->lateness = duration_stats(lateness_us);
    timing->missed_deadlines = missed;
    timing->watchdog_trips = watchdog_trips;
    timing->watchdog_ramped_ticks = ramp.reduced_ticks();
    timing->stalled_ticks = stalled;
    timing->force_cpu_s = force_cpu_s;
    timing->force_involuntary_switches = force_switches;
    timing->machine_steal_s = std::max(0.0, machine_steal_s() - steal_before_s);
    timing->scheduler = scheduler;
    std::vector<double> slice_us(relax_slice_ns.size());
    double busy_ns = 0.0;
    for (std::size_t i = 0; i < slice_us.size(); ++i) {
      slice_us[i] = 1e-3 * static_cast<double>(relax_slice_ns[i]);
      busy_ns += static_cast<double>(relax_slice_ns[i]);
    }
    timing->relax_slice = duration_stats(slice_us);
    timing->relax_cpu_s = relax_cpu_s;
    timing->relax_slice_max_deletions = max_slice_work.deletions;
    timing->relax_slice_max_steps = max_slice_work.relax_steps;
    timing->relax_slice_ns = std::move(relax_slice_ns);
    timing->relax_slice_start_ns = std::move(relax_slice_start_ns);
    timing->wall_time_s = 1e-9 * static_cast<double>(ns_between(start, wall_end));
    timing->achieved_rate_hz =
        static_cast<double>(summary.ticks) /
        (1e-9 * static_cast<double>(rows.back().start_ns + rows.back().compute_ns));
    timing->relax_busy_fraction =
        timing->wall_time_s > 0.0 ? 1e-9 * busy_ns / timing->wall_time_s : 0.0;
  }
  if (sculpt != nullptr) {
    // The threads are joined: apply any last changes, no reader to wait for.
    drain_relaxation(*sculpt->mass, *sculpt->channel);
    std::vector<openvdb::Coord> published;
    sculpt->field->publish_unsynchronized(*sculpt->mass, feed != nullptr ? &published : nullptr);
    if (feed != nullptr) {
      // This thread is the voxel queue's producer now; the render thread still drains it.
      feed->voxels.offer(published, *sculpt->mass);
      while (!feed->voxels.drained_backlog() && !render_finished.load(std::memory_order_acquire)) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        feed->voxels.offer({}, *sculpt->mass);
      }
    }
    sculpted.plastic_events = plastic_events;
    sculpted.queue_overflows = sculpt->channel->overflows();
    sculpted.max_queue_depth = max_queue_depth;
    sculpted.deleted_voxels = sculpt->mass->work().deleted_voxels;
    sculpted.relaxed_voxels = sculpt->mass->work().relaxed_voxels;
    sculpted.final_mass_units = sculpt->mass->total_mass_units();
    sculpted.settled = sculpt->mass->settled();
    if (sculpt_summary != nullptr) *sculpt_summary = sculpted;
  }
  if (feed != nullptr) {
    feed->done.store(true, std::memory_order_release);
    render_thread.join();
    if (render_error) std::rethrow_exception(render_error);
    if (timing != nullptr) {
      std::vector<double> frame_us(render_timing.frame_ns.size());
      for (std::size_t i = 0; i < frame_us.size(); ++i) {
        frame_us[i] = 1e-3 * static_cast<double>(render_timing.frame_ns[i]);
      }
      timing->render_frame = duration_stats(frame_us);
      if (frame_us.size() > 1) {
        const double span_s = 1e-9 * static_cast<double>(render_timing.frame_start_ns.back() +
                                                         render_timing.frame_ns.back() -
                                                         render_timing.frame_start_ns.front());
        timing->render_fps = span_s > 0.0 ? static_cast<double>(frame_us.size()) / span_s : 0.0;
      }
      timing->render_queue_full = feed->voxels.full_events();
      timing->render = std::move(render_timing);
    }
  }
  return summary;
}

}  // namespace hapvox::haptics
