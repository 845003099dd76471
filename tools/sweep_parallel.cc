#include "tools/sweep_parallel.h"

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "engine/errors.h"
#include "tools/cli.h"
#include "tools/sweep_slurm.h"

namespace hapvox::cli {

namespace fs = std::filesystem;

void check_hosts_file(const std::string& hosts_file) {
  std::ifstream in(hosts_file);
  if (!fs::is_regular_file(hosts_file) || !in) throw InputError(hosts_file, "cannot be read");
  int hosts = 0, line_number = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_number;
    const std::size_t start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#') continue;
    // parallel reads the line as a command line for ssh: a quote or a `$` would be code.
    if (line.find_first_of("'\"`$;|&<>") != std::string::npos) {
      throw InputError(hosts_file + ":" + std::to_string(line_number),
                       "a host line holds a quote or a shell character");
    }
    ++hosts;
  }
  if (hosts == 0)
    throw InputError(hosts_file, "names no host (one [N/]host per line; ':' for this machine)");
}

int run_over_hosts(const SweepPlan& plan, const std::string& hosts_file) {
  if (run_shell("parallel --version").exit_code != 0) {
    throw InputError("--hosts",
                     "GNU parallel is not on this machine's PATH (Debian: apt-get "
                     "install parallel)");
  }
  const std::string rows = plan.dir + "/parallel.rows";
  {
    std::ofstream out(rows);
    for (const std::size_t i : plan.to_run) out << plan.ids[i] << "\n";
    if (!out.flush()) throw InputError(rows, "cannot be written");
  }
  const std::string manifest = fs::absolute(plan.manifest.source).lexically_normal().string();
  // The command each job runs on its host, {} replaced by the row's ID.
  const std::string job = "hapvox sweep " + shell_quoted(manifest) + " -o " +
                          shell_quoted(plan.dir) + " -j 1 --task-rows {}";
  const std::string command = "parallel --will-cite --sshloginfile " +
                              shell_quoted(fs::absolute(hosts_file).string()) + " --arg-file " +
                              shell_quoted(rows) + " --joblog " +
                              shell_quoted(plan.dir + "/parallel.log") + " " + shell_quoted(job);
  const ShellResult r = run_shell(command);
  std::ofstream(plan.dir + "/parallel.out") << r.output;
  return r.exit_code;
}

}  // namespace hapvox::cli
