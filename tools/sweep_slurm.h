#pragma once
// A sweep on a Slurm cluster (`hapvox sweep MANIFEST -o DIR --slurm`, docs/sweeps.md): the
// rows to run become one job array, a few rows per array task, each task running its rows
// with `hapvox sweep MANIFEST -o DIR -j 1 --task-rows ID,ID,...` on its node. It assumes
// only a filesystem every node shares (DIR, the manifest and its inputs) and `hapvox` on
// the nodes' PATH; sbatch, squeue and scancel on the submitting machine's.

#include <atomic>
#include <string>

#include "tools/sweep_plan.h"

namespace hapvox::cli {

struct SlurmOptions {
  std::string partition;  // "": the cluster's default
  std::string
      time;  // a task's time limit in Slurm's forms ("30", "2:00:00", "1-0"); "": the partition's
  int max_parallel = 0;   // array tasks running at once (the array's %K); 0: no limit
  int rows_per_task = 0;  // 0: 4, or more where the rows would need over 1000 tasks
};

/// Checks the options (InputError naming the flag) and DIR (no whitespace: #SBATCH lines).
void check_slurm_options(const SlurmOptions& options, const std::string& dir);

/// Writes DIR/sweep.sbatch, the job array of the plan's rows to run, and makes DIR/slurm/
/// (the tasks' output). Returns the script's path. The plan must have rows to run.
std::string write_slurm_script(const SweepPlan& plan, const SlurmOptions& options);

/// Submits `script` with `sbatch --parsable`: the job's ID, also written to DIR/slurm.job.
/// InputError("--slurm", ...) with sbatch's own words when it is missing or refuses.
std::string submit_slurm_script(const std::string& script, const std::string& dir);

/// Follows job `job_id` until none of its tasks is queued or running, with a progress line
/// on a terminal (rows of the plan done so far). False when `stop` was set first (the job
/// keeps running). InputError("squeue", ...) when squeue fails for a minute.
bool wait_for_slurm_job(const std::string& job_id, const SweepPlan& plan,
                        const std::atomic<bool>& stop);

/// The tasks of DIR's last submitted job still queued or running (0 when there is no job
/// file, or squeue knows the job no more).
int slurm_tasks_left(const std::string& dir);

/// Output and exit status of `/bin/sh -c command` (stdout and stderr together).
struct ShellResult {
  int exit_code = 0;
  std::string output;
};
ShellResult run_shell(const std::string& command);

}  // namespace hapvox::cli
