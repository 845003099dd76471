#pragma once
// A sweep over ssh hosts with GNU parallel (`hapvox sweep MANIFEST -o DIR --hosts FILE`,
// docs/sweeps.md), for labs without a scheduler: one parallel job per row, each
// `hapvox sweep MANIFEST -o DIR -j 1 --task-rows ID` on a host of FILE (parallel's
// --sshloginfile: one `[N/]host` per line, `:` for this machine). Like the Slurm backend it
// assumes a filesystem every host shares and `hapvox` on the hosts' PATH.

#include <string>

#include "tools/sweep_plan.h"

namespace hapvox::cli {

/// Checks that `hosts_file` is a readable file naming at least one host (InputError naming
/// it and its line otherwise).
void check_hosts_file(const std::string& hosts_file);

/// Runs the plan's rows to run through `parallel` and waits for it; its output goes to
/// DIR/parallel.out, its job log (a line per row: host, exit status) to DIR/parallel.log.
/// Returns parallel's exit status. InputError("--hosts", ...) when GNU parallel is missing.
int run_over_hosts(const SweepPlan& plan, const std::string& hosts_file);

}  // namespace hapvox::cli
