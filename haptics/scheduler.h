#pragma once
// Best timing the machine allows for the force thread, each step tried and reported:
//
//   timer slack   prctl(PR_SET_TIMERSLACK, 1 ns): sleeps otherwise overshoot by ~50 us
//   memory lock   mlockall(MCL_CURRENT | MCL_FUTURE): no page faults in the loop
//   policy        SCHED_FIFO at a set priority: not preempted by ordinary threads
//   affinity      pinned to one CPU (the last online one by default): no migrations
//
// None of them is required. What was refused (no CAP_SYS_NICE in a container, a low
// RLIMIT_MEMLOCK, a sanitizer build) is reported with the reason and the loop runs with
// the fallback, which the report names. The engine starts no threads: the caller applies
// the process-wide steps before starting its force thread and the thread steps from it.

#include <string>

namespace hapvox::haptics {

struct SchedulerOptions {
  bool lock_memory = true;
  /// Also lock what is mapped later (MCL_FUTURE). Off when a render thread runs: llvmpipe
  /// maps buffers every frame, and locking (pre-faulting) each one slows frames tenfold.
  bool lock_future_memory = true;
  bool realtime_policy = true;
  int fifo_priority = 80;  // 1..99
  bool pin_cpu = true;
  int cpu = -1;  // -1: the last online CPU
};

/// One line per step: "on (...)" or "off: <reason>; <fallback>".
struct SchedulerReport {
  std::string timer_slack;
  std::string memory_lock;
  std::string policy;
  std::string affinity;
  bool all_granted() const;
};

/// Process-wide steps (memory lock); call on the main thread before starting the loop.
void prepare_process(const SchedulerOptions& options, SchedulerReport& report);

/// CPU time of the calling thread, seconds (CLOCK_THREAD_CPUTIME_ID).
double thread_cpu_s();
/// Undoes prepare_process (unlocks memory) after the loop.
void release_process(const SchedulerReport& report);
/// Per-thread steps (timer slack, policy, affinity); call on the force thread itself.
/// Never throws, never allocates when every step is granted or refused with an errno
/// (the report strings are filled by the caller from the codes afterwards).
struct ThreadSetupCodes {
  int timer_slack_errno = -1;  // -1: not tried; 0: granted; else errno
  int policy_errno = -1;
  int affinity_errno = -1;
  int cpu = -1;
  int priority = 0;
};
void prepare_force_thread(const SchedulerOptions& options, ThreadSetupCodes& codes);
/// Fills the per-thread lines of `report` from `codes`.
void describe_thread_setup(const SchedulerOptions& options, const ThreadSetupCodes& codes,
                           SchedulerReport& report);

}  // namespace hapvox::haptics
