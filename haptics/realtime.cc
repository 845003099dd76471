#include "haptics/realtime.h"

#include <pthread.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <array>
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
#include "haptics/elapsed_ns.h"
#include "haptics/scheduler.h"
#include "haptics/spsc_ring.h"

namespace hapvox::haptics {
namespace {

using Clock = std::chrono::steady_clock;

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

// Pins the calling thread to every CPU but the force thread's (when it is pinned and there
// is another).
void keep_off_force_cpu(const SchedulerOptions& scheduler) {
  const long online = sysconf(_SC_NPROCESSORS_ONLN);
  if (!scheduler.pin_cpu || online < 2) return;
  const int force_cpu = scheduler.cpu >= 0 ? scheduler.cpu : static_cast<int>(online - 1);
  cpu_set_t others;
  CPU_ZERO(&others);
  for (int cpu = 0; cpu < online; ++cpu) {
    if (cpu != force_cpu) CPU_SET(cpu, &others);
  }
  pthread_setaffinity_np(pthread_self(), sizeof others, &others);
}

// One tick's row on its way from the force thread to the session writer.
struct RingSlot {
  TickRecord row;
  std::uint8_t nonfinite = 0;
};

// Rows from the force thread to the session writer: the force thread pushes without waiting
// (a full ring drops the row and counts it; at 8 s of rows, only a writer stalled that long
// by the disk gets there), the writer thread pops.
class RowRing {
 public:
  void push(const RingSlot& slot) {
    if (!ring_.try_push(slot)) dropped_.fetch_add(1, std::memory_order_relaxed);
  }
  bool pop(RingSlot& slot) { return ring_.try_pop(slot); }
  std::uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  SpscRing<RingSlot, 8192> ring_;
  std::atomic<std::uint64_t> dropped_{0};
};

// Paced lockstep: the force thread hands tick k's row over here once its force is sent; the
// background thread does the stage's lockstep work for it, fills its fields and marks it
// done; tick k+1's force stage waits for that. Both sides block (futex waits through
// std::atomic::wait) rather than spin: a SCHED_FIFO thread that spins spends the kernel's
// real-time budget, and when that runs out every real-time thread on the CPU stops.
struct PacedHandoff {
  alignas(64) std::atomic<std::int64_t> ready{-1};  // the last tick handed over
  alignas(64) std::atomic<std::int64_t> done{-1};   // the last tick whose work is done
  alignas(64) std::atomic<std::uint32_t> wake{0};   // bumped on every handover and at the end
  RingSlot slot;                                    // that tick's row

  // Force thread. No allocation, no lock: a store, and a futex wake when the other waits.
  void hand_over(std::int64_t tick, const RingSlot& row) {
    slot = row;
    ready.store(tick, std::memory_order_release);
    wake_background();
  }
  void wake_background() {
    wake.fetch_add(1, std::memory_order_release);
    wake.notify_one();
  }
  void wait_done(std::int64_t tick) const {
    for (std::int64_t d = done.load(std::memory_order_acquire); d < tick;
         d = done.load(std::memory_order_acquire)) {
      done.wait(d, std::memory_order_acquire);
    }
  }
  // Background thread.
  void mark_done(std::int64_t tick) {
    done.store(tick, std::memory_order_release);
    done.notify_one();
  }
};

// The paced background thread runs SCHED_FIFO just below the force thread (which waits for
// it every tick), but its work per tick has no bound (a stroke's flows): were it to take
// over ~95 % of its CPU for a second, the kernel's RT throttling would stop it, and with it
// the force loop, for a second or more. So it watches its own busy fraction and steps down
// to SCHED_OTHER (at nice kDemotedNice) while it is over kDemoteAbove, back once under
// kPromoteBelow.
class FifoBudget {
 public:
  static constexpr auto kWindow = std::chrono::milliseconds(200);
  static constexpr double kDemoteAbove = 0.75;
  static constexpr double kPromoteBelow = 0.40;
  static constexpr int kDemotedNice = -10;

  FifoBudget(const SchedulerOptions& scheduler, Clock::time_point now) : window_start_(now) {
    if (!scheduler.realtime_policy) return;
    prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
    setpriority(PRIO_PROCESS, 0, kDemotedNice);  // this thread only (Linux); for SCHED_OTHER
    fifo_param_.sched_priority = std::max(1, scheduler.fifo_priority - 1);
    fifo_ = pthread_setschedparam(pthread_self(), SCHED_FIFO, &fifo_param_) == 0;
    granted_ = fifo_;  // refused (no CAP_SYS_NICE): SCHED_OTHER throughout
  }
  // One tick's work, from `begin` to `end`.
  void add(Clock::time_point begin, Clock::time_point end) {
    busy_ns_ += ns_between(begin, end);
    const std::int64_t window_ns = ns_between(window_start_, end);
    if (window_ns < std::chrono::nanoseconds(kWindow).count()) return;
    const double busy = static_cast<double>(busy_ns_) / static_cast<double>(window_ns);
    if (fifo_ && busy > kDemoteAbove) {
      sched_param normal{};
      fifo_ = pthread_setschedparam(pthread_self(), SCHED_OTHER, &normal) != 0;
      if (!fifo_) ++demotions_;
    } else if (granted_ && !fifo_ && busy < kPromoteBelow) {
      fifo_ = pthread_setschedparam(pthread_self(), SCHED_FIFO, &fifo_param_) == 0;
    }
    window_start_ = end;
    busy_ns_ = 0;
  }
  std::size_t demotions() const { return demotions_; }

 private:
  sched_param fifo_param_{};
  bool granted_ = false;  // SCHED_FIFO was granted at the start
  bool fifo_ = false;     // SCHED_FIFO now
  Clock::time_point window_start_;
  std::int64_t busy_ns_ = 0;
  std::size_t demotions_ = 0;
};

// The background thread of paced lockstep: each handed-over tick's lockstep work, in order,
// until the force thread is done and nothing is left.
void run_paced_background(BackgroundStage& background, PacedHandoff& handoff,
                          const std::atomic<bool>& force_done, const SchedulerOptions& scheduler,
                          Clock::time_point start, RenderFeed* feed,
                          const LockstepRender* paced_render, BackgroundTiming& timing) {
  pthread_setname_np(pthread_self(), "hapvox-relax");
  FifoBudget budget(scheduler, Clock::now());
  keep_off_force_cpu(scheduler);  // the force thread's CPU is its own
  const double cpu_start = thread_cpu_s();
  std::int64_t next = 0;
  while (true) {
    const std::uint32_t wake = handoff.wake.load(std::memory_order_acquire);
    if (handoff.ready.load(std::memory_order_acquire) < next) {
      if (force_done.load(std::memory_order_acquire) &&
          handoff.ready.load(std::memory_order_acquire) < next) {
        break;
      }
      if (feed != nullptr) feed->voxels.retry_patches();
      handoff.wake.wait(wake, std::memory_order_acquire);  // until the next handover or the end
      continue;
    }
    TickRecord& row = handoff.slot.row;
    const auto begin = Clock::now();
    background.run_lockstep_tick(static_cast<std::size_t>(next), row, paced_render);
    if (feed != nullptr) feed->voxels.retry_patches();
    const auto end = Clock::now();
    if (row.deleted_voxels > 0 || row.relaxed_voxels > 0) {
      timing.slice_ns.push_back(ns_between(begin, end));
      timing.slice_start_ns.push_back(ns_between(start, begin));
      timing.slice_max_deletions =
          std::max(timing.slice_max_deletions, static_cast<std::size_t>(row.deleted_voxels));
      timing.slice_max_steps =
          std::max(timing.slice_max_steps, static_cast<std::size_t>(row.relaxed_voxels));
    }
    budget.add(begin, end);
    handoff.mark_done(next);
    ++next;
  }
  timing.cpu_s = thread_cpu_s() - cpu_start;
  timing.fifo_demotions = budget.demotions();
}

}  // namespace

ReplaySummary replay_realtime(ForceStage& force, BackgroundStage* background, Device& device,
                              const DeviceLimits& limits, SessionWriter* session,
                              const ProgressFn& progress, SculptSummary* sculpt_summary,
                              TimingSummary* timing, const RealtimeOptions& options) {
  SummaryBuilder builder(device);
  // A device with a stylus orientation: the session records it per tick.
  if (session != nullptr && device.reports_orientation()) session->record_orientation();
  const std::size_t ticks = device.tick_count();  // kUnbounded: until the device finishes
  if (ticks == 0) return builder.finish(0, 0);
  const auto dt = std::chrono::nanoseconds(std::llround(1e9 / device.rate_hz()));

  // Everything the force thread touches is made here, before it starts. Rows go to the
  // session through a fixed ring, so a session of any length takes the same memory.
  auto rows = std::make_unique<RowRing>();
  std::atomic<bool> force_done{false};
  if (background != nullptr) background->begin();
  ForceSafety safety(limits, device.rate_hz());

  const ForceThreadHooks& hooks = options.hooks;
  const std::int64_t period_ns = dt.count();
  const auto watchdog_ns = static_cast<std::int64_t>(std::llround(
      options.watchdog_periods > 0.0 ? options.watchdog_periods * static_cast<double>(period_ns)
                                     : std::max(0.0, options.watchdog_ms) * 1e6));
  SchedulerReport scheduler;
  prepare_process(options.scheduler, scheduler);
  ThreadSetupCodes thread_codes;
  std::size_t watchdog_trips = 0;
  double force_cpu_s = 0.0;
  long force_switches = 0;
  BackgroundTiming background_timing;
  const double steal_before_s = machine_steal_s();

  // The render thread's feed, made before any thread starts.
  std::unique_ptr<RenderFeed> feed;
  RenderTiming render_timing;
  if (options.render_loop) feed = std::make_unique<RenderFeed>();
  std::exception_ptr render_error;
  std::atomic<bool> render_finished{false};
  // Paced lockstep: tick k's row goes to the background thread, which does the stage's
  // lockstep work for it and fills its fields; tick k+1 waits for that.
  const bool paced = options.background_in_lockstep && background != nullptr;
  auto handoff = std::make_unique<PacedHandoff>();
  LockstepRender paced_render;  // the background stage's changes, to the render thread
  paced_render.every_ticks = 0;
  const auto start = Clock::now() + std::chrono::milliseconds(5);
  std::thread force_thread([&] {
    pthread_setname_np(pthread_self(), "hapvox-force");
    prepare_force_thread(options.scheduler, thread_codes);
    const double cpu_start = thread_cpu_s();
    const long switches_start = involuntary_switches();
    if (hooks.loop_started) hooks.loop_started();
    bool handed = false;  // paced: a row is with the background thread
    auto take_back = [&](std::int64_t tick) {
      handoff->wait_done(tick);
      rows->push(handoff->slot);
      handed = false;
    };
    for (std::size_t tick = 0; tick < ticks; ++tick) {
      if (options.stop != nullptr && options.stop->load(std::memory_order_relaxed)) break;
      const auto deadline =
          device.wait_for_tick(tick, start + static_cast<std::int64_t>(tick) * dt);
      if (device.finished()) break;
      const auto begin = Clock::now();
      // The state this tick reads is the one after the last tick's background work.
      if (handed) take_back(static_cast<std::int64_t>(tick) - 1);
      if (hooks.before_tick) hooks.before_tick(tick);
      RingSlot slot;
      TickRecord& row = slot.row;
      force.acquire_published();
      slot.nonfinite = run_force_stage(force, device, tick, limits, safety, row) ? 1 : 0;
      const auto end = Clock::now();
      if (background != nullptr && !paced) background->fill_realtime_row(row);
      row.scheduled_ns = ns_between(start, deadline);
      row.start_ns = ns_between(start, begin);
      row.compute_ns = ns_between(begin, end);
      if (row.start_ns + row.compute_ns > row.scheduled_ns + watchdog_ns) {
        // A stall: this tick's force is late but fresh and finite, so it is sent as
        // computed (zeroing it would be a step). From the next tick on the ramp takes the
        // force down to zero and back in, at the ramp-in's slope.
        row.watchdog = 1;
        ++watchdog_trips;
        safety.ramp.trip();
      }
      if (feed != nullptr) {
        feed->tool.publish(RenderToolState{row.tool_position_mm, row.displacement_mm,
                                           row.contact != 0, static_cast<std::int64_t>(tick)});
      }
      if (paced) {
        handoff->hand_over(static_cast<std::int64_t>(tick), slot);
        handed = true;
      } else {
        rows->push(slot);
      }
    }
    if (handed) take_back(handoff->ready.load(std::memory_order_relaxed));
    if (hooks.loop_finished) hooks.loop_finished();
    force_cpu_s = thread_cpu_s() - cpu_start;
    force_switches = involuntary_switches() - switches_start;
    // Back to the ordinary policy before waiting on other threads: a SCHED_FIFO thread
    // spinning on yield() would starve them on its CPU.
    if (thread_codes.policy_errno == 0) {
      sched_param normal{};
      pthread_setschedparam(pthread_self(), SCHED_OTHER, &normal);
    }
    if (background != nullptr && !paced) {
      // Hand over what is still pending before the background thread finishes. Keep
      // taking up its publications: it may be waiting for that before it can drain the
      // queue that this flush waits for.
      while (!force.flush_handoffs()) {
        force.acquire_published();
        std::this_thread::yield();
      }
    }
    force_done.store(true, std::memory_order_release);
    if (paced) {
      handoff->wake_background();  // a waiting background thread finishes
    } else if (background != nullptr) {
      background->wake();  // an idle background thread finishes
    }
  });
  std::thread background_thread;
  if (paced) {
    if (feed != nullptr) {
      paced_render.voxel_changed = [&feed](const openvdb::Coord& ijk, float density) {
        feed->voxels.offer_patch(VoxelPatch{ijk, density});
      };
      // The render thread's copy of a FEM step (allocates in the first few slots only).
      paced_render.mesh_changed = [&feed](std::int64_t tick, const engine::fem::TetMesh& mesh,
                                          int mesh_index, const std::vector<double>& u_mm) {
        MeshDisplacement& out = feed->mesh.write_slot();
        out.tick = tick;
        out.mesh = &mesh;
        out.mesh_index = mesh_index;
        out.displacement_mm = u_mm;
        feed->mesh.publish();
      };
    }
    background_thread = std::thread([&] {
      run_paced_background(*background, *handoff, force_done, options.scheduler, start, feed.get(),
                           feed != nullptr ? &paced_render : nullptr, background_timing);
    });
  } else if (background != nullptr) {
    background_thread = std::thread([&] {
      pthread_setname_np(pthread_self(), "hapvox-relax");
      background->run_realtime(force_done, start, feed.get(), background_timing);
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
      keep_off_force_cpu(options.scheduler);
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

  // This thread: the session writer. It drains the ring ~10 times a second into the
  // session and the summary; the force thread never waits for it.
  LatencyHistogram lateness;
  std::size_t written = 0, missed = 0, stalled = 0;
  std::uint64_t watchdog_seen = 0, stats_written = 0;  // for the feed's LoopStats
  std::int64_t last_mass_units = 0;
  auto stats_time = start;
  std::int64_t first_scheduled_ns = 0, last_end_ns = 0;
  const std::size_t progress_every =
      ticks == Device::kUnbounded ? 1000 : std::max<std::size_t>(1, ticks / 100);
  std::size_t next_progress = progress_every;
  auto drain = [&](bool loop_running) {
    RingSlot slot;
    while (rows->pop(slot)) {
      const TickRecord& row = slot.row;
      builder.add(row, slot.nonfinite != 0);
      if (session != nullptr) session->append(row);
      lateness.add(row.start_ns - row.scheduled_ns);
      if (row.start_ns + row.compute_ns > row.scheduled_ns + period_ns) ++missed;
      if (row.start_ns - row.scheduled_ns > period_ns) ++stalled;
      if (written == 0) first_scheduled_ns = row.scheduled_ns;  // a live device's first
      last_end_ns = row.start_ns + row.compute_ns;
      watchdog_seen += row.watchdog;
      last_mass_units = row.total_mass_units;
      ++written;
    }
    if (feed != nullptr) {
      const auto now = Clock::now();
      const double span_s = std::chrono::duration<double>(now - stats_time).count();
      LoopStats& loop = feed->loop;
      // The rate over the last ~100 ms while the loop runs; the drain after it ended (a span
      // the loop ran only part of, often none) keeps the last, as the window's last frame
      // shows it.
      if (span_s > 0.0 && loop_running) {
        loop.rate_hz.store(static_cast<double>(written - stats_written) / span_s,
                           std::memory_order_relaxed);
      }
      stats_time = now;
      stats_written = written;
      loop.ticks.store(written, std::memory_order_relaxed);
      loop.missed.store(missed, std::memory_order_relaxed);
      loop.watchdog_trips.store(watchdog_seen, std::memory_order_relaxed);
      loop.total_mass_units.store(last_mass_units, std::memory_order_relaxed);
      loop.p99_lateness_us.store(1e-3 * static_cast<double>(lateness.percentile_ns(99.0)),
                                 std::memory_order_relaxed);
    }
    if (progress && written >= next_progress) {
      progress(written, ticks);
      next_progress = (written / progress_every + 1) * progress_every;
    }
  };
  while (!force_done.load(std::memory_order_acquire)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    drain(!force_done.load(std::memory_order_acquire));
  }
  force_thread.join();
  drain(false);
  if (background_thread.joinable()) background_thread.join();
  const auto wall_end = Clock::now();
  release_process(scheduler);
  describe_thread_setup(options.scheduler, thread_codes, scheduler);

  const ForceStageCounters counters = force.counters();
  const ReplaySummary summary = builder.finish(counters.nonfinite_forces, counters.contact_onsets);
  if (timing != nullptr) {
    timing->rate_hz = device.rate_hz();
    timing->lateness = duration_stats(lateness);
    timing->missed_deadlines = missed;
    timing->watchdog_ms = 1e-6 * static_cast<double>(watchdog_ns);
    timing->watchdog_trips = watchdog_trips;
    timing->watchdog_ramped_ticks = safety.ramp.reduced_ticks();
    timing->stalled_ticks = stalled;
    timing->force_cpu_s = force_cpu_s;
    timing->force_involuntary_switches = force_switches;
    timing->machine_steal_s = std::max(0.0, machine_steal_s() - steal_before_s);
    timing->scheduler = scheduler;
    std::vector<double> slice_us(background_timing.slice_ns.size());
    double busy_ns = 0.0;
    for (std::size_t i = 0; i < slice_us.size(); ++i) {
      slice_us[i] = 1e-3 * static_cast<double>(background_timing.slice_ns[i]);
      busy_ns += static_cast<double>(background_timing.slice_ns[i]);
    }
    timing->relax_slice = duration_stats(slice_us);
    timing->relax_cpu_s = background_timing.cpu_s;
    timing->relax_fifo_demotions = background_timing.fifo_demotions;
    timing->relax_slice_max_deletions = background_timing.slice_max_deletions;
    timing->relax_slice_max_steps = background_timing.slice_max_steps;
    timing->relax_slice_ns = std::move(background_timing.slice_ns);
    timing->relax_slice_start_ns = std::move(background_timing.slice_start_ns);
    timing->wall_time_s = 1e-9 * static_cast<double>(ns_between(start, wall_end));
    // From the first tick's schedule (a trace's: the start; a live device's: its first
    // position) to the end of the last.
    const std::int64_t span_ns = last_end_ns - first_scheduled_ns;
    timing->achieved_rate_hz =
        span_ns > 0 ? static_cast<double>(written) / (1e-9 * static_cast<double>(span_ns)) : 0.0;
    timing->rows_dropped = rows->dropped();
    timing->relax_busy_fraction =
        timing->wall_time_s > 0.0 ? 1e-9 * busy_ns / timing->wall_time_s : 0.0;
  }
  if (background != nullptr) {
    // The threads are joined: the background stage completes its work, no reader to wait
    // for; the render thread (still running) gets the last changes.
    SculptSummary sculpted;
    if (paced) {
      // As the lockstep replay ends: what the force stage holds back is handed over, and
      // the stage completes its work (its changed voxels still go to the render thread).
      force.flush_handoffs();
      sculpted = background->finish(feed != nullptr ? &paced_render : nullptr, nullptr, nullptr);
      while (feed != nullptr && !feed->voxels.retry_patches() &&
             !render_finished.load(std::memory_order_acquire)) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
    } else {
      sculpted = background->finish(nullptr, feed.get(), &render_finished);
    }
    sculpted.plastic_events = summary.plastic_events;
    sculpted.max_queue_depth = summary.max_queue_depth;
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
