#include "tools/sweep_parallel.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <utility>

#include "engine/errors.h"
#include "tools/cli.h"
#include "tools/sweep_pool.h"
#include "tools/sweep_slurm.h"

namespace hapvox::cli {
namespace fs = std::filesystem;

void check_hosts_run(const std::string& hosts_file, const std::string& dir,
                     const std::string& manifest_path) {
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
  if (hosts == 0) {
    throw InputError(hosts_file, "names no host (one [N/]host per line; ':' for this machine)");
  }
  // parallel replaces {}, {1}, {#}, {/} ... anywhere in the command it runs.
  const std::pair<std::string, const char*> paths[] = {{dir, "--output"},
                                                       {manifest_path, "manifest"}};
  for (const auto& [path, flag] : paths) {
    if (path.find_first_of("{}") != std::string::npos) {
      throw InputError(flag, "'" + path + "' holds a brace, which GNU parallel would replace");
    }
  }
  require_program("parallel", "--hosts", "Debian: apt-get install parallel");
}

int run_over_hosts(const SweepPlan& plan, const std::string& hosts_file,
                   const std::atomic<bool>& stop) {
  const std::string rows = plan.dir + "/parallel.rows";
  {
    std::ofstream out(rows);
    for (std::size_t k = 0; k < plan.to_run.size(); ++k) {
      out << task_rows_text(plan, k, k + 1) << "\n";
    }
    if (!out.flush()) throw InputError(rows, "cannot be written");
  }
  const std::string manifest = fs::absolute(plan.manifest.source).lexically_normal().string();
  // The command each job runs on its host, {} replaced by the row's INDEX:ID.
  const std::string job = "hapvox sweep " + shell_quoted(manifest) + " -o " +
                          shell_quoted(plan.dir) + " -j 1 --task-rows {}";
  const std::string command = "exec parallel --will-cite --sshloginfile " +
                              shell_quoted(fs::absolute(hosts_file).string()) + " --arg-file " +
                              shell_quoted(rows) + " --joblog " +
                              shell_quoted(plan.dir + "/parallel.log") + " " + shell_quoted(job);
  // One job in the sweep's pool: its output to DIR/parallel.out, SIGTERM once `stop` is set.
  PoolJob job_of_parallel;
  job_of_parallel.executable = "/bin/sh";
  job_of_parallel.args = {"-c", command};
  job_of_parallel.working_dir = plan.dir;
  job_of_parallel.log_path = plan.dir + "/parallel.out";
  JobStatus status = 0;
  run_pool(
      {job_of_parallel}, 1, "sh", stop, [](std::size_t) {},
      [&](std::size_t, JobStatus end) { status = end; });
  return status;
}

}  // namespace hapvox::cli
