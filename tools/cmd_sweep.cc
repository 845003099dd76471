// hapvox sweep MANIFEST -o DIR: every replay a manifest describes (haptics/sweep_manifest.h),
// each as `hapvox replay ... -o ID.h5` run in DIR, then DIR/summary.csv and summary.h5
// (tools/sweep_summary.h). docs/sweeps.md. Where the rows run:
//   (default)      a local pool of processes, -j at a time (tools/sweep_pool.h);
//   --slurm        a Slurm job array (tools/sweep_slurm.h); --wait follows it to the end;
//   --emit slurm   that job's script, written and not submitted;
//   --hosts FILE   ssh hosts through GNU parallel (tools/sweep_parallel.h);
//   --collect DIR  none: the summary of what DIR holds (after a job ran).
// Each backend's jobs run `hapvox sweep MANIFEST -o DIR -j 1 --task-rows INDEX:ID,...` (the
// pool with only those rows, no summary). One sweep at a time runs in DIR (DIR/sweep.lock),
// and none while a Slurm job of DIR still has tasks queued or running.
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
#include "tools/command_exit.h"
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

[[noreturn]] void exit_with(int code) { throw CommandExit{code}; }

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
  // A killed sweep's leftovers of the rows to run (DIR is this sweep's, under its lock): the
  // rows run again, and a replay refuses to write over a .partial it did not make.
  for (const std::size_t i : plan.to_run) fs::remove(plan.file(i, ".h5.partial"));
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

// After a Slurm job or parallel ended: the summary, rows left not run counted as failed.
[[noreturn]] void summarise_ended(SweepPlan& plan, const std::string& backend) {
  refresh_outcomes(plan);
  const SweepCounts c = summarise_sweep(plan);
  if (c.not_run > 0) {
    std::printf(
        "  not run          %zu rows: %s ended without them (see their ID.log); rerun the "
        "sweep to run them\n",
        c.not_run, backend.c_str());
  }
  exit_with(exit_code_for(c.failed + c.not_run));
}

// "  slurm ..." lines on DIR's last job; its tasks still queued or running.
int report_slurm_job(const std::string& dir) {
  const SlurmJobLeft left = slurm_job_left(dir);
  if (!left.unknown.empty()) {
    std::printf("  slurm            cannot tell whether the job of %s/slurm.job runs (%s)\n",
                dir.c_str(), left.unknown.c_str());
  } else if (left.tasks > 0) {
    std::printf(
        "  slurm            job %s: %d tasks still queued or running (the summary holds "
        "the rows done so far)\n",
        left.job.text().c_str(), left.tasks);
  }
  return left.tasks;
}

// --collect DIR: the summary of what a sweep's directory holds, nothing run. Exit 0 only
// when every row is done (a job still running has rows not run).
[[noreturn]] void collect(const std::string& dir) {
  const std::string manifest = manifest_of_sweep_dir(dir);
  const SweepPlan plan = plan_sweep(manifest, dir, false);
  const SweepDirLock lock(plan.dir);
  std::printf("sweep %s: %zu rows in %s (collected)\n", manifest.c_str(), plan.manifest.rows.size(),
              plan.dir.c_str());
  report_slurm_job(plan.dir);
  const SweepCounts c = summarise_sweep(plan);
  exit_with(exit_code_for(c.failed + c.not_run));
}

// Flags that mean nothing without the backend they belong to, or with --collect.
void check_flag_combinations(const SweepFlags& f, CLI::App& cmd) {
  auto given = [&](const char* name) { return cmd.count(name) > 0; };
  if (!f.collect.empty()) {
    for (const char* name : {"manifest", "--output", "--jobs", "--retry-failed", "--dry-run",
                             "--slurm", "--emit", "--wait", "--partition", "--time",
                             "--max-parallel", "--rows-per-task", "--hosts", "--task-rows"}) {
      if (given(name)) {
        throw InputError("--collect", std::string("takes the directory alone (not ") +
                                          (name[0] == '-' ? name : "a manifest") + ")");
      }
    }
    return;
  }
  if (f.manifest.empty()) throw InputError("sweep", "needs a manifest (or --collect DIR)");
  if (f.output_dir.empty()) throw InputError("--output", "a directory is required");
  if (f.jobs < 0) throw InputError("-j", "must be at least 1 (0: one per core)");
  if (!f.emit.empty() && f.emit != "slurm") {
    throw InputError("--emit", "'" + f.emit + "' is not a backend (slurm)");
  }
  if (f.slurm && !f.emit.empty()) {
    throw InputError("--emit", "writes the script instead of --slurm");
  }
  const bool slurm = f.slurm || !f.emit.empty();
  if (f.wait && !f.slurm) throw InputError("--wait", "needs --slurm");
  for (const char* name : {"--partition", "--time", "--max-parallel", "--rows-per-task"}) {
    if (given(name) && !slurm) throw InputError(name, "needs --slurm or --emit slurm");
  }
  if (!f.hosts.empty() && slurm) throw InputError("--hosts", "cannot be combined with --slurm");
  if (!f.task_rows.empty() && (slurm || !f.hosts.empty() || f.retry_failed || f.dry_run)) {
    throw InputError("--task-rows",
                     "runs a job's rows here, alone (what a Slurm or parallel "
                     "job runs)");
  }
}

// A job's task (--task-rows): its rows in the local pool, no summary.
[[noreturn]] void run_task(const SweepFlags& f, int parallel) {
  SweepPlan plan = plan_task(f.manifest, f.output_dir, parse_task_rows(f.task_rows));
  std::printf("sweep %s: %zu rows of a job -> %s (%zu to run, %d at a time)\n", f.manifest.c_str(),
              plan.to_run.size() + plan.done_before, plan.dir.c_str(), plan.to_run.size(),
              parallel);
  const bool finished = run_locally(plan, parallel);
  std::size_t failed = 0;
  for (const std::size_t i : plan.to_run) failed += plan.outcomes[i].status == "failed";
  exit_with(finished ? exit_code_for(failed) : 130);
}

void run_sweep(const SweepFlags& f, CLI::App& cmd) {
  check_flag_combinations(f, cmd);
  if (!f.collect.empty()) collect(f.collect);
  const int parallel =
      f.jobs > 0 ? f.jobs : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  if (!f.task_rows.empty()) run_task(f, parallel);
  const bool slurm = f.slurm || !f.emit.empty();
  // Everything checked before a row runs or DIR is made.
  if (!f.hosts.empty()) check_hosts_run(f.hosts, f.output_dir, f.manifest);
  SweepPlan plan = plan_sweep(f.manifest, f.output_dir, f.retry_failed);
  if (slurm) check_slurm_options(f.slurm_options, plan.dir, f.manifest, plan.to_run.size());
  if (f.slurm) {
    require_program("sbatch", "--slurm",
                    "is this a Slurm login node? --emit slurm writes the script alone");
    require_program("squeue", "--slurm", "is this a Slurm login node?");
  }
  if (!f.dry_run) {
    // A job of DIR still running would run the rows it has not finished a second time.
    const SlurmJobLeft left = slurm_job_left(plan.dir);
    if (left.tasks > 0) {
      throw InputError(plan.dir, "Slurm job " + left.job.text() + " still has " +
                                     std::to_string(left.tasks) +
                                     " tasks queued or running (wait for it, or scancel " +
                                     left.job.id + "; hapvox sweep --collect DIR gathers it)");
    }
  }
  const SweepDirLock lock(plan.dir);
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
  write_row_commands(plan);
  if (f.dry_run) {
    for (const std::size_t i : plan.to_run) {
      std::printf("  %s\n", shell_command(haptics::sweep_replay_arguments(plan.manifest.rows[i],
                                                                          plan.ids[i] + ".h5"))
                                .c_str());
    }
    return;
  }
  end_session_on_signals();  // Ctrl-C or SIGTERM: the rows stop, the summary is written
  const std::atomic<bool>& stop = *stop_request();

  if (slurm) {
    if (plan.to_run.empty()) {
      std::printf("  slurm            nothing to submit\n");
      summarise_ended(plan, "the sweep");
    }
    const std::string script = write_slurm_script(plan, f.slurm_options);
    if (!f.emit.empty()) {
      std::printf(
          "  slurm            %s (submit it with: sbatch %s; then: hapvox sweep "
          "--collect %s)\n",
          script.c_str(), script.c_str(), plan.dir.c_str());
      return;
    }
    const SlurmJob job = submit_slurm_script(script, plan.dir);
    std::printf("  slurm            job %s submitted (%s; its tasks' output in %s/slurm/)\n",
                job.text().c_str(), script.c_str(), plan.dir.c_str());
    if (!f.wait) {
      std::printf("  collect          hapvox sweep --collect %s (once it has run)\n",
                  plan.dir.c_str());
      return;
    }
    std::fflush(stdout);
    if (!wait_for_slurm_job(job, plan, stop)) {
      std::printf(
          "  slurm            interrupted: job %s runs on (scancel %s stops it; hapvox "
          "sweep --collect %s gathers it)\n",
          job.text().c_str(), job.id.c_str(), plan.dir.c_str());
      exit_with(130);
    }
    summarise_ended(plan, "Slurm job " + job.text());
  }
  if (!f.hosts.empty()) {
    std::fflush(stdout);
    const int status = plan.to_run.empty() ? 0 : run_over_hosts(plan, f.hosts, stop);
    std::printf(
        "  parallel         exit %d (its job log: %s/parallel.log, its output: "
        "%s/parallel.out)\n",
        status, plan.dir.c_str(), plan.dir.c_str());
    if (stop.load()) {
      refresh_outcomes(plan);
      summarise_sweep(plan);
      exit_with(130);
    }
    summarise_ended(plan, "GNU parallel");
  }

  const bool finished = run_locally(plan, parallel);
  const SweepCounts c = summarise_sweep(plan);
  exit_with(finished ? exit_code_for(c.failed) : 130);
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
                  "Run only these rows (INDEX:ID, comma-separated) and write no summary: what "
                  "each Slurm or parallel job runs");
  cmd->callback([flags, cmd] { run_sweep(*flags, *cmd); });
}

}  // namespace hapvox::cli
