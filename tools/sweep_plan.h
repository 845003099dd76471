#pragma once
// Where a sweep stands (tools/cmd_sweep.cc): its manifest's rows, checked, with their IDs,
// and what DIR already holds of each (done, failed, not run). Every backend (the local pool,
// a Slurm job array, GNU parallel over ssh) runs the rows a plan says are to run, and
// `--collect` reads a plan again once they have run.

#include <cstddef>
#include <string>
#include <vector>

#include "haptics/sweep_manifest.h"
#include "tools/sweep_summary.h"

namespace hapvox::cli {

struct SweepPlan {
  haptics::SweepManifest manifest;
  std::string dir;  // absolute
  std::vector<std::string> ids;
  std::vector<SweepOutcome> outcomes;  // by row: what DIR holds
  std::vector<std::size_t> to_run;     // rows neither done nor (without retry) failed
  std::size_t done_before = 0, failed_before = 0;

  /// DIR/ID.EXT of row `i`.
  std::string file(std::size_t i, const char* ext) const;
  /// "MANIFEST:LINE" of row `i`.
  std::string at(std::size_t i) const;
};

/// Reads and checks the manifest (every row's files exist, its flags parse as `hapvox
/// replay`'s, no two rows are the same replay, DIR/summary.* spares every input) and reads
/// where each row stands in `output_dir` (which need not exist). `retry_failed`: failed rows
/// are to run again. InputError naming the manifest's line for a bad row, before anything
/// is written.
SweepPlan plan_sweep(const std::string& manifest_path, const std::string& output_dir,
                     bool retry_failed);

/// One row of a job's task (`--task-rows INDEX:ID,...`): its index in the manifest and the
/// ID it had when the job was written.
struct TaskRow {
  std::size_t index = 0;
  std::string id;
};

/// Parses `--task-rows` ("INDEX:ID,INDEX:ID,..."). InputError("--task-rows", ...).
std::vector<TaskRow> parse_task_rows(const std::string& text);

/// `--task-rows`' text for the plan's rows to run from `from` to `to` (exclusive).
std::string task_rows_text(const SweepPlan& plan, std::size_t from, std::size_t to);

/// The plan of a job's task: only `rows` are checked and hashed (a task reads only its own
/// rows' files, which its replays read anyway), and those not done are to run (a failed one
/// again: the job was written to run it). InputError("--task-rows", ...) when a row is not
/// in the manifest or its ID changed (the manifest or one of its files changed since the
/// job was written).
SweepPlan plan_task(const std::string& manifest_path, const std::string& output_dir,
                    const std::vector<TaskRow>& rows);

/// Holds DIR/sweep.lock (flock) while one sweep runs, submits or summarises in DIR, so that
/// two cannot run the same rows at once. InputError(DIR, ...) when another holds it.
class SweepDirLock {
 public:
  explicit SweepDirLock(const std::string& dir);
  ~SweepDirLock();
  SweepDirLock(const SweepDirLock&) = delete;
  SweepDirLock& operator=(const SweepDirLock&) = delete;

 private:
  int fd_ = -1;
};

/// Reads again where each row stands in DIR (after a job or GNU parallel ran them): done,
/// failed or not run, whatever the plan said before.
void refresh_outcomes(SweepPlan& plan);

/// Writes DIR/ID.cmd for each row to run (`cd DIR && hapvox replay ...`: a row's replay by
/// hand) and DIR/sweep.manifest (the manifest's path, for `--collect DIR`).
void write_row_commands(const SweepPlan& plan);

/// The manifest path a sweep's directory was run from (DIR/sweep.manifest), or InputError.
std::string manifest_of_sweep_dir(const std::string& dir);

/// Counts of a plan's outcomes.
struct SweepCounts {
  std::size_t done = 0, failed = 0, not_run = 0;
};
SweepCounts count_outcomes(const SweepPlan& plan);

/// Writes DIR/summary.csv and DIR/summary.h5, prints the rows line, each failed row, and the
/// summary's paths.
SweepCounts summarise_sweep(const SweepPlan& plan);

/// "hapvox ARG ARG ...", each argument quoted for a POSIX shell.
std::string shell_command(const std::vector<std::string>& args);

}  // namespace hapvox::cli
