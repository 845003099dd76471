#include "haptics/scheduler.h"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace hapvox::haptics {
namespace {

// Sanitizers map terabytes of shadow memory: locking it all would exhaust the machine.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitizerBuild = true;
#else
constexpr bool kSanitizerBuild = false;
#endif

std::string refused(int code, const char* fallback) {
  return std::string("off: ") + std::strerror(code) + "; " + fallback;
}

}  // namespace

double thread_cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

bool SchedulerReport::all_granted() const {
  for (const std::string* line : {&timer_slack, &memory_lock, &policy, &affinity}) {
    if (line->rfind("on", 0) != 0) return false;
  }
  return true;
}

void prepare_process(const SchedulerOptions& options, SchedulerReport& report) {
  if (!options.lock_memory) {
    report.memory_lock = "off: not requested; pages may fault in the loop";
  } else if (kSanitizerBuild) {
    report.memory_lock = "off: sanitizer build; pages may fault in the loop";
  } else if (mlockall(options.lock_future_memory ? MCL_CURRENT | MCL_FUTURE : MCL_CURRENT) == 0) {
    report.memory_lock =
        options.lock_future_memory
            ? "on (mlockall current and future)"
            : "on (mlockall current; not future: the render thread maps per frame)";
  } else {
    report.memory_lock = refused(errno, "pages may fault in the loop (raise ulimit -l)");
  }
}

void release_process(const SchedulerReport& report) {
  if (report.memory_lock.rfind("on", 0) == 0) munlockall();
}

void prepare_force_thread(const SchedulerOptions& options, ThreadSetupCodes& codes) {
  codes.timer_slack_errno = prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL) == 0 ? 0 : errno;
  if (options.realtime_policy) {
    sched_param param{};
    param.sched_priority = options.fifo_priority;
    codes.priority = options.fifo_priority;
    codes.policy_errno = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
  }
  if (options.pin_cpu) {
    const long online = sysconf(_SC_NPROCESSORS_ONLN);
    codes.cpu = options.cpu >= 0 ? options.cpu : static_cast<int>(online > 0 ? online - 1 : 0);
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(codes.cpu, &set);
    codes.affinity_errno = pthread_setaffinity_np(pthread_self(), sizeof(set), &set);
  }
}

void describe_thread_setup(const SchedulerOptions& options, const ThreadSetupCodes& codes,
                           SchedulerReport& report) {
  report.timer_slack =
      codes.timer_slack_errno == 0
          ? "on (1 ns)"
          : refused(codes.timer_slack_errno, "sleeps may overshoot; spin covers it");
  if (!options.realtime_policy) {
    report.policy = "off: not requested; SCHED_OTHER, may be preempted";
  } else if (codes.policy_errno == 0) {
    report.policy = "on (SCHED_FIFO priority " + std::to_string(codes.priority) + ")";
  } else {
    report.policy =
        refused(codes.policy_errno, "SCHED_OTHER, may be preempted (needs CAP_SYS_NICE)");
  }
  if (!options.pin_cpu) {
    report.affinity = "off: not requested; the kernel may migrate the thread";
  } else if (codes.affinity_errno == 0) {
    report.affinity = "on (CPU " + std::to_string(codes.cpu) + ")";
  } else {
    report.affinity = refused(codes.affinity_errno, "the kernel may migrate the thread");
  }
}

}  // namespace hapvox::haptics
