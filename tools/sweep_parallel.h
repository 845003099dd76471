#pragma once
// A sweep over ssh hosts with GNU parallel (`hapvox sweep MANIFEST -o DIR --hosts FILE`,
// docs/sweeps.md), for labs without a scheduler: one parallel job per row, each
// `hapvox sweep MANIFEST -o DIR -j 1 --task-rows INDEX:ID` on a host of FILE (parallel's
// --sshloginfile: one `[N/]host` per line, `:` for this machine). Like the Slurm backend it
// assumes a filesystem every host shares and `hapvox` on the hosts' PATH.

#include <atomic>
#include <string>

#include "tools/sweep_plan.h"

namespace hapvox::cli {

/// Checks that `hosts_file` is a readable file naming at least one host, that GNU parallel
/// is installed, and that DIR and the manifest's path hold no brace (parallel would read
/// `{...}` as its own replacement strings). InputError naming the file, its line or flag.
void check_hosts_run(const std::string& hosts_file, const std::string& dir,
                     const std::string& manifest_path);

/// Runs the plan's rows to run through `parallel` and waits for it; its output goes to
/// DIR/parallel.out as it comes, its job log (a line per row: host, exit status) to
/// DIR/parallel.log. Once `stop` is set parallel is sent SIGTERM (it stops its jobs).
/// Returns parallel's exit status (128 + a signal that ended it).
int run_over_hosts(const SweepPlan& plan, const std::string& hosts_file,
                   const std::atomic<bool>& stop);

}  // namespace hapvox::cli
