#pragma once
// A sweep on a Slurm cluster (`hapvox sweep MANIFEST -o DIR --slurm`, docs/sweeps.md): the
// rows to run become one job array, a few rows per array task, each task running its rows
// with `hapvox sweep MANIFEST -o DIR -j 1 --task-rows INDEX:ID,...` on its node. It assumes
// only a filesystem every node shares (DIR, the manifest and its inputs) and `hapvox` on
// the nodes' PATH; sbatch and squeue on the submitting machine's.

#include <atomic>
#include <cstddef>
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

/// Checks the options, DIR and the manifest's path (no characters an #SBATCH line or Slurm's
/// %-patterns would change) and that `rows` fit in one job array. InputError naming the flag.
void check_slurm_options(const SlurmOptions& options, const std::string& dir,
                         const std::string& manifest_path, std::size_t rows);

/// InputError(flag, ...) when `program` is not on the PATH.
void require_program(const std::string& program, const std::string& flag, const std::string& hint);

/// Writes DIR/sweep.sbatch, the job array of the plan's rows to run, makes DIR/slurm/ (the
/// tasks' output) and removes DIR/slurm.job (the script's tasks write their job's ID there
/// when it was submitted by hand). Returns the script's path. The plan must have rows to run.
std::string write_slurm_script(const SweepPlan& plan, const SlurmOptions& options);

/// A submitted job: its ID and, on a federation of clusters, its cluster.
struct SlurmJob {
  std::string id;
  std::string cluster;
  std::string text() const { return cluster.empty() ? id : id + " on " + cluster; }
};

/// Submits `script` with `sbatch --parsable`: the job, also written to DIR/slurm.job.
/// InputError("--slurm", ...) with sbatch's own words when it refuses.
SlurmJob submit_slurm_script(const std::string& script, const std::string& dir);

/// Follows `job` until none of its tasks is queued or running, with a progress line on a
/// terminal (rows of the plan run so far). False when `stop` was set first (the job keeps
/// running). InputError("squeue", ...) when squeue fails for a minute.
bool wait_for_slurm_job(const SlurmJob& job, const SweepPlan& plan, const std::atomic<bool>& stop);

/// DIR's last job (DIR/slurm.job) and how many of its tasks are still queued or running.
struct SlurmJobLeft {
  bool has_job = false;  // DIR/slurm.job names one
  SlurmJob job;
  int tasks = 0;        // queued or running (0: over, or squeue knows it no more)
  std::string unknown;  // why squeue could not tell ("" when it could)
};
SlurmJobLeft slurm_job_left(const std::string& dir);

/// Output and exit status of `/bin/sh -c command` (stdout and stderr together).
struct ShellResult {
  int exit_code = 0;
  std::string output;
};
ShellResult run_shell(const std::string& command);

}  // namespace hapvox::cli
