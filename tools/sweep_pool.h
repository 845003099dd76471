#pragma once
// A local pool of child processes for `hapvox sweep` (tools/cmd_sweep.cc): each job is this
// program (or, for GNU parallel, another) run with its own arguments, working directory and
// log file, at most N at once. A process per replay: a row that crashes takes only itself down, and
// a replay's realtime scheduling or memory is its own.

#include <atomic>
#include <functional>
#include <string>
#include <vector>

namespace hapvox::cli {

struct PoolJob {
  std::string executable = "/proc/self/exe";  // this program, unless another is named
  std::vector<std::string> args;              // after the program name
  std::string working_dir;
  std::string log_path;  // the child's stdout and stderr
};

/// How a job ended: its exit code, or 128 + the signal that killed it.
using JobStatus = int;

/// Runs `jobs` in order, at most `parallel` at once, each as its executable with argv[0]
/// `program` and the job's arguments. `on_start(i)` and `on_end(i, status)` run on the
/// calling thread. Once `stop` is set no job starts, and those running are sent SIGTERM and
/// waited for (their on_end gets their status). Throws InputError("sweep", ...) when a child
/// cannot be started at all (no fork, no such program).
void run_pool(const std::vector<PoolJob>& jobs, int parallel, const std::string& program,
              const std::atomic<bool>& stop, const std::function<void(std::size_t)>& on_start,
              const std::function<void(std::size_t, JobStatus)>& on_end);

}  // namespace hapvox::cli
