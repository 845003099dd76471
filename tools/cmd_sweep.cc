// hapvox sweep MANIFEST -o DIR: every replay a manifest describes (haptics/sweep_manifest.h),
// each as `hapvox replay ... -o ID.h5` run in DIR, then DIR/summary.csv and summary.h5
// (tools/sweep_summary.h). docs/sweeps.md. Where the rows run:
//   (default)      a local pool of processes, -j at a time (tools/sweep_pool.h);
//   --slurm        a Slurm job array (tools/sweep_slurm.h); --wait follows it to the end;
//   --emit slurm   that job's script, written and not submitted;
//   --hosts FILE   ssh hosts through GNU parallel (tools/sweep_parallel.h);
//   --collect DIR  none: the summary of what DIR holds (after a job ran).
// Each backend's jobs run `hapvox sweep MANIFEST -o DIR -j 1 --task-rows ID,...` (the pool
// with only those rows, no summary).
//
// A row is done when DIR/ID.h5 exists (a replay writes ID.h5.partial and renames it only
// once whole), failed when DIR/ID.failed does; a rerun runs only the rows that are neither
// (a killed sweep's), and --retry-failed the failed ones again. DIR/ID.cmd is each row's
// command (run it in DIR to get the same session), DIR/ID.log its output.
// Exit 0 when every row is done, 2 for a bad manifest or flag (before any row runs),
// 100 + the number of failed rows (at most 199) otherwise, 130 when interrupted; once a
// Slurm job or parallel has ended, rows it left not run count as failed.

#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <thread>

#include "engine/errors.h"
#include "tools/cli.h"
#include "tools/replay_command.h"
#include "tools/sweep_parallel.h"
#include "tools/sweep_plan.h"
#include "tools/sweep_pool.h"
#include "tools/sweep_slurm.h"

namespace hapvox::cli {
namespace {

namespace fs = std::filesystem;

struct SweepFlags {
  std::string manifest;
  std::string output_dir;
  int jobs = 0;  // 0: the number of cores
  bool retry_failed = false;
  bool dry_run = false;
  bool slurm = false;
  std::string emit;
  bool wait = false;
  SlurmOptions slurm_options;
  std::string hosts;
  std::string collect;
  std::string task_rows;
};

// The last line of a failed row's output that says something.
std::string last_line(const std::string& log_path) {
  std::ifstream in(log_path);
  std::string line, last;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  }
  return last;
}

[[noreturn]] void exit_with(int code) {
  std::fflush(stdout);
  std::fflush(stderr);
  std::_Exit(code);
}

// 100 + the rows that failed (at most 199), or 0.
int exit_code_for(std::size_t failed) {
  return failed == 0 ? 0 : 100 + static_cast<int>(std::min<std::size_t>(failed, 99));
}

// Runs the plan's rows to run in a local pool; the outcomes follow. False when interrupted.
bool run_locally(SweepPlan& plan, int parallel) {
  std::vector<PoolJob> jobs;
  for (const std::size_t i : plan.to_run) {
    PoolJob job;
    job.args = haptics::sweep_replay_arguments(plan.manifest.rows[i], plan.ids[i] + ".h5");
    job.working_dir = plan.dir;
    job.log_path = plan.file(i, ".log");
    jobs.push_back(std::move(job));
  }
  end_session_on_signals();  // Ctrl-C or SIGTERM: the running rows stop, the summary is written
  const std::atomic<bool>& stop = *stop_request();
  const bool tty = isatty(STDERR_FILENO) != 0;
  std::size_t finished = 0, failed = 0, running = 0;
  auto progress = [&] {
    if (!tty) return;
    std::fprintf(stderr, "\rsweep: %zu/%zu rows run, %zu failed, %zu running   ", finished,
                 plan.to_run.size(), failed, running);
  };
  run_pool(
      jobs, parallel, "hapvox", stop,
      [&](std::size_t) {
        ++running;
        progress();
      },
      [&](std::size_t j, JobStatus status) {
        const std::size_t i = plan.to_run[j];
        SweepOutcome& o = plan.outcomes[i];
        --running;
        fs::remove(plan.file(i, ".h5.partial"));
        if (fs::exists(o.session)) {  // whole (renamed last), however the process ended
          o.status = "done";
          fs::remove(plan.file(i, ".failed"));
        } else if (stop.load() && status == 128 + SIGTERM) {
          o.status = "not run";  // stopped by us: runs again next time
          return;
        } else {
          o.status = "failed";
          o.error = "exit " + std::to_string(status) + ": " + last_line(plan.file(i, ".log"));
          std::ofstream(plan.file(i, ".failed")) << o.error << "\n";
          ++failed;
        }
        ++finished;
        progress();
      });
  if (tty) std::fprintf(stderr, "\n");
  return !stop.load();
}

std::vector<std::string> split_ids(const std::string& text) {
  std::vector<std::string> ids;
  std::stringstream in(text);
  for (std::string id; std::getline(in, id, ',');) {
    if (!id.empty()) ids.push_back(id);
  }
  if (ids.empty()) throw InputError("--task-rows", "names no row");
  return ids;
}

// After a Slurm job or parallel ended: the summary, rows left not run counted as failed.
void summarise_ended(const std::string& manifest, const std::string& dir, const char* backend) {
  SweepPlan plan = plan_sweep(manifest, dir, false);
  const SweepCounts c = summarise_sweep(plan);
  if (c.not_run > 0) {
    std::printf(
        "  not run          %zu rows: %s ended without them (see their ID.log); rerun the "
        "sweep to run them\n",
        c.not_run, backend);
  }
  exit_with(exit_code_for(c.failed + c.not_run));
}

void run_sweep(const SweepFlags& f) {
  // --collect DIR: the summary of a sweep's directory, nothing run.
  if (!f.collect.empty()) {
    if (!f.manifest.empty())
      throw InputError("--collect", "takes the directory alone, no manifest");
    const std::string manifest = manifest_of_sweep_dir(f.collect);
    SweepPlan plan = plan_sweep(manifest, f.collect, false);
    std::printf("sweep %s: %zu rows in %s (collected)\n", manifest.c_str(),
                plan.manifest.rows.size(), plan.dir.c_str());
    const int left = slurm_tasks_left(plan.dir);
    const SweepCounts c = summarise_sweep(plan);
    if (left > 0) {
      std::printf(
          "  slurm            %d tasks still queued or running: the summary holds the "
          "rows done so far\n",
          left);
      exit_with(exit_code_for(c.failed));
    }
    exit_with(exit_code_for(c.failed + c.not_run));
  }
  // Everything checked before a row runs or DIR is made.
  if (f.manifest.empty()) throw InputError("sweep", "needs a manifest (or --collect DIR)");
  if (f.jobs < 0) throw InputError("-j", "must be at least 1 (0: one per core)");
  if (!f.emit.empty() && f.emit != "slurm") {
    throw InputError("--emit", "'" + f.emit + "' is not a backend (slurm)");
  }
  const bool slurm = f.slurm || !f.emit.empty();
  if (f.slurm && !f.emit.empty())
    throw InputError("--emit", "writes the script instead of --slurm");
  if (f.wait && !f.slurm) throw InputError("--wait", "needs --slurm");
  if (!f.hosts.empty() && slurm) throw InputError("--hosts", "cannot be combined with --slurm");
  if (!f.task_rows.empty() && (slurm || !f.hosts.empty())) {
    throw InputError("--task-rows", "runs rows here (it is what a Slurm or parallel job runs)");
  }
  if (!f.hosts.empty()) check_hosts_file(f.hosts);
  SweepPlan plan = plan_sweep(f.manifest, f.output_dir, f.retry_failed);
  if (slurm) check_slurm_options(f.slurm_options, plan.dir);
  if (!f.task_rows.empty()) keep_only(plan, split_ids(f.task_rows), "--task-rows");
  const int parallel =
      f.jobs > 0 ? f.jobs : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  const char* where = slurm              ? "as a Slurm job array"
                      : !f.hosts.empty() ? "over ssh hosts with GNU parallel"
                                         : nullptr;
  std::printf("sweep %s: %zu rows -> %s (%zu to run, ", f.manifest.c_str(),
              plan.manifest.rows.size(), plan.dir.c_str(), plan.to_run.size());
  if (where != nullptr) {
    std::printf("%s", where);
  } else {
    std::printf("%d at a time", parallel);
  }
  std::printf("; %zu done before, %zu failed before%s)\n", plan.done_before, plan.failed_before,
              plan.failed_before > 0 ? ": --retry-failed runs them" : "");
  if (f.task_rows.empty()) write_row_commands(plan);  // a job's task: written at submission
  if (f.dry_run) {
    for (const std::size_t i : plan.to_run) {
      std::printf("  %s\n", shell_command(haptics::sweep_replay_arguments(plan.manifest.rows[i],
                                                                          plan.ids[i] + ".h5"))
                                .c_str());
    }
    return;
  }

  if (slurm) {
    if (plan.to_run.empty()) {
      std::printf("  slurm            nothing to submit\n");
      summarise_ended(f.manifest, f.output_dir, "the sweep");
    }
    const std::string script = write_slurm_script(plan, f.slurm_options);
    if (!f.emit.empty()) {
      std::printf(
          "  slurm            %s (submit it with: sbatch %s; then: hapvox sweep --collect "
          "%s)\n",
          script.c_str(), script.c_str(), plan.dir.c_str());
      return;
    }
    const std::string job = submit_slurm_script(script, plan.dir);
    std::printf("  slurm            job %s submitted (%s; its tasks' output in %s/slurm/)\n",
                job.c_str(), script.c_str(), plan.dir.c_str());
    if (!f.wait) {
      std::printf("  collect          hapvox sweep --collect %s (once it has run)\n",
                  plan.dir.c_str());
      return;
    }
    std::fflush(stdout);
    end_session_on_signals();
    if (!wait_for_slurm_job(job, plan, *stop_request())) {
      std::printf(
          "  slurm            interrupted: job %s runs on (scancel %s stops it; hapvox "
          "sweep --collect %s gathers it)\n",
          job.c_str(), job.c_str(), plan.dir.c_str());
      exit_with(130);
    }
    summarise_ended(f.manifest, f.output_dir, ("Slurm job " + job).c_str());
  }
  if (!f.hosts.empty()) {
    std::fflush(stdout);
    const int status = plan.to_run.empty() ? 0 : run_over_hosts(plan, f.hosts);
    std::printf("  parallel         exit %d (its job log: %s/parallel.log)\n", status,
                plan.dir.c_str());
    summarise_ended(f.manifest, f.output_dir, "GNU parallel");
  }

  const bool finished = run_locally(plan, parallel);
  if (!f.task_rows.empty()) {
    // A Slurm or parallel job's rows: whoever follows the job writes the summary.
    std::size_t failed = 0;
    for (const std::size_t i : plan.to_run) failed += plan.outcomes[i].status == "failed";
    if (!finished) exit_with(130);
    exit_with(exit_code_for(failed));
  }
  const SweepCounts c = summarise_sweep(plan);
  if (!finished) exit_with(130);
  exit_with(exit_code_for(c.failed));
}

}  // namespace

void add_sweep_command(CLI::App& app) {
  auto flags = std::make_shared<SweepFlags>();
  CLI::App* cmd = app.add_subcommand(
      "sweep",
      "Run every replay a TOML manifest describes (traces x volumes x models x materials x "
      "options, and explicit rows), each into DIR/ID.h5: in a local pool of processes, as a "
      "Slurm job array (--slurm) or over ssh hosts with GNU parallel (--hosts); rerun to finish "
      "the rows not done; DIR/summary.csv and summary.h5 at the end (docs/sweeps.md)");
  cmd->add_option("manifest", flags->manifest, "The sweep's manifest (.toml)");
  cmd->add_option("--output,-o", flags->output_dir, "The sweep's directory");
  cmd->add_option("-j,--jobs", flags->jobs, "Replays at once (0: one per core)")
      ->capture_default_str();
  cmd->add_flag("--retry-failed", flags->retry_failed, "Run the rows that failed before again");
  cmd->add_flag("--dry-run", flags->dry_run,
                "Print the commands of the rows to run (and write DIR/ID.cmd), run none");
  cmd->add_flag("--slurm", flags->slurm,
                "Submit the rows as a Slurm job array (sbatch); needs DIR on a filesystem the "
                "nodes share and hapvox on their PATH");
  cmd->add_option("--emit", flags->emit,
                  "Write the job script (slurm: DIR/sweep.sbatch) without submitting it");
  cmd->add_flag("--wait", flags->wait, "With --slurm: follow the job to its end, then summarise");
  cmd->add_option("--partition", flags->slurm_options.partition, "Slurm partition (--slurm)");
  cmd->add_option("--time", flags->slurm_options.time,
                  "Each array task's time limit, as Slurm writes it (--slurm)");
  cmd->add_option("--max-parallel", flags->slurm_options.max_parallel,
                  "Array tasks running at once (--slurm; 0: no limit)")
      ->capture_default_str();
  cmd->add_option("--rows-per-task", flags->slurm_options.rows_per_task,
                  "Rows each array task runs (--slurm; 0: 4, more past 4000 rows)")
      ->capture_default_str();
  cmd->add_option("--hosts", flags->hosts,
                  "Run the rows over these ssh hosts with GNU parallel (its --sshloginfile; ':' "
                  "is this machine)");
  cmd->add_option("--collect", flags->collect,
                  "Write the summary of a sweep's directory (after a Slurm job), run nothing");
  cmd->add_option("--task-rows", flags->task_rows,
                  "Run only these rows (IDs, comma-separated) and write no summary: what each "
                  "Slurm or parallel job runs");
  cmd->callback([flags] {
    if (flags->collect.empty() && flags->output_dir.empty()) {
      throw InputError("--output", "a directory is required");
    }
    run_sweep(*flags);
  });
}

}  // namespace hapvox::cli
