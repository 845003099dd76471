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

/// Narrows the rows to run to those whose IDs are listed (what a Slurm array task or a GNU
/// parallel job runs; a listed row that failed before runs again, a done one does not).
/// InputError(source, ...) for an ID the manifest has no row for (the manifest changed
/// since the job was written).
void keep_only(SweepPlan& plan, const std::vector<std::string>& ids, const std::string& source);

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
