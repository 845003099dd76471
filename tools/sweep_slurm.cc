#include "tools/sweep_slurm.h"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

#include "engine/errors.h"
#include "engine/io/output_file.h"
#include "engine/io/text.h"
#include "engine/text_file.h"
#include "tools/cli.h"

namespace hapvox::cli {
namespace {

namespace fs = std::filesystem;

// Slurm's own limit on array indices (MaxArraySize's default, 1001: indices 0..1000).
constexpr std::size_t kMaxArrayTasks = 1001;
constexpr int kDefaultRowsPerTask = 4;

int rows_per_task(const SlurmOptions& options, std::size_t rows) {
  if (options.rows_per_task > 0) return options.rows_per_task;
  const std::size_t needed = (rows + kMaxArrayTasks - 1) / kMaxArrayTasks;
  return std::max<int>(kDefaultRowsPerTask, static_cast<int>(needed));
}

// sbatch's or squeue's words, on one line.
std::string one_line(const std::string& output) {
  std::string line = engine::io::trim(output);
  std::replace(line.begin(), line.end(), '\n', ' ');
  return line.empty() ? "(no output)" : line;
}

// "ID" or "ID;CLUSTER" (sbatch --parsable's answer, and DIR/slurm.job's text).
bool parse_job(const std::string& text, SlurmJob* job) {
  const std::string line = engine::io::trim(text);
  const std::size_t semicolon = line.find(';');
  job->id = line.substr(0, semicolon);
  job->cluster = semicolon == std::string::npos ? "" : line.substr(semicolon + 1);
  return !job->id.empty() && job->id.find_first_not_of("0123456789") == std::string::npos &&
         std::regex_match(job->cluster, std::regex("[A-Za-z0-9_.-]*"));
}

}  // namespace

ShellResult run_shell(const std::string& command) {
  ShellResult result;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) {
    result.exit_code = 127;
    return result;
  }
  char buffer[4096];
  std::size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0) result.output.append(buffer, n);
  const int status = ::pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return result;
}

void require_program(const std::string& program, const std::string& flag, const std::string& hint) {
  if (run_shell("command -v " + shell_quoted(program)).exit_code != 0) {
    throw InputError(flag, program + " is not on this machine's PATH (" + hint + ")");
  }
}

void check_slurm_options(const SlurmOptions& options, const std::string& dir,
                         const std::string& manifest_path, std::size_t rows) {
  // Only what sbatch takes as one word on an #SBATCH line.
  if (!std::regex_match(options.partition, std::regex("[A-Za-z0-9_.,-]*"))) {
    throw InputError("--partition", "'" + options.partition + "' is not a partition name");
  }
  if (!options.time.empty() &&
      !std::regex_match(options.time, std::regex("([0-9]+-)?[0-9]+(:[0-9]+){0,2}"))) {
    throw InputError("--time", "'" + options.time +
                                   "' is not a Slurm time (MINUTES, H:MM:SS, DAYS-HOURS, "
                                   "DAYS-H:MM:SS)");
  }
  if (options.max_parallel < 0) throw InputError("--max-parallel", "must be 0 (no limit) or more");
  if (options.rows_per_task < 0) {
    throw InputError("--rows-per-task", "must be 0 (automatic) or more");
  }
  // Slurm expands %A, %a, %j ... in --output's path; #SBATCH lines take one plain word.
  if (dir.find_first_of(" \t\r\n'\"\\$`%") != std::string::npos) {
    throw InputError("--output",
                     "a Slurm sweep's directory may not hold spaces, quotes, '\\', '$', '`' or "
                     "'%' (#SBATCH lines take one plain word)");
  }
  if (manifest_path.find_first_of("\r\n") != std::string::npos) {
    throw InputError(manifest_path, "a manifest's path with a line break cannot go in a script");
  }
  const int per_task = rows_per_task(options, rows);
  const std::size_t tasks = (rows + per_task - 1) / per_task;
  if (tasks > kMaxArrayTasks) {
    throw InputError("--rows-per-task",
                     std::to_string(per_task) + " rows per task make " + std::to_string(tasks) +
                         " array tasks; Slurm takes at most " + std::to_string(kMaxArrayTasks));
  }
}

std::string write_slurm_script(const SweepPlan& plan, const SlurmOptions& options) {
  const std::size_t rows = plan.to_run.size();
  const int per_task = rows_per_task(options, rows);
  const std::size_t tasks = (rows + per_task - 1) / per_task;
  const std::string manifest = fs::absolute(plan.manifest.source).lexically_normal().string();
  fs::create_directories(plan.dir + "/slurm");
  fs::remove(plan.dir + "/slurm.job");  // this job's ID goes there, once it has one
  const std::string path = plan.dir + "/sweep.sbatch";
  {
    std::ostringstream out;
    out << "#!/bin/bash\n"
        << "# " << manifest << " as a Slurm job array, written by hapvox sweep: " << rows
        << " rows in " << tasks << (tasks == 1 ? " task" : " tasks") << " of up to " << per_task
        << ".\n"
        << "# Task K runs the rows on line K of `rows` (INDEX:ID: the manifest's row and its\n"
        << "# ID) with `hapvox sweep --task-rows`; each row's session is DIR/ID.h5, its output\n"
        << "# ID.log. Assumes only that DIR (" << plan.dir << "), the manifest and\n"
        << "# its traces, volumes and materials lie on a filesystem every node shares, and\n"
        << "# that `hapvox` is on the nodes' PATH (sbatch passes on the submitting shell's\n"
        << "# environment by default).\n"
        << "# Submit: sbatch " << path << "; then: hapvox sweep --collect " << plan.dir << "\n"
        << "#SBATCH --job-name=hapvox-sweep\n"
        << "#SBATCH --array=0-" << tasks - 1
        << (options.max_parallel > 0 ? "%" + std::to_string(options.max_parallel) : "") << "\n"
        << "#SBATCH --chdir=" << plan.dir << "\n"
        << "#SBATCH --output=" << plan.dir << "/slurm/%A_%a.out\n"
        << "#SBATCH --ntasks=1\n"
        << "#SBATCH --cpus-per-task=1\n";
    if (!options.partition.empty()) out << "#SBATCH --partition=" << options.partition << "\n";
    if (!options.time.empty()) out << "#SBATCH --time=" << options.time << "\n";
    out << "set -eu\n"
        << "rows=(\n";
    for (std::size_t t = 0; t < tasks; ++t) {
      out << "  " << task_rows_text(plan, t * per_task, std::min(rows, (t + 1) * per_task)) << "\n";
    }
    const std::string dir = shell_quoted(plan.dir);
    out << ")\n"
        << "# The job's ID, for `hapvox sweep --collect` (a job submitted by hand).\n"
        << "if [ -n \"${SLURM_ARRAY_JOB_ID:-}\" ]; then\n"
        << "  echo \"$SLURM_ARRAY_JOB_ID\" > " << dir << "/slurm/job.$SLURM_ARRAY_TASK_ID\n"
        << "  mv -f " << dir << "/slurm/job.$SLURM_ARRAY_TASK_ID " << dir << "/slurm.job\n"
        << "fi\n"
        << "exec hapvox sweep " << shell_quoted(manifest) << " -o " << dir
        << " -j 1 --task-rows \"${rows[$SLURM_ARRAY_TASK_ID]}\"\n";
    engine::io::write_text_atomically(path, out.str());
  }
  return path;
}

SlurmJob submit_slurm_script(const std::string& script, const std::string& dir) {
  const ShellResult r = run_shell("sbatch --parsable " + shell_quoted(script));
  if (r.exit_code != 0) {
    throw InputError("--slurm", "sbatch refused the job: " + one_line(r.output));
  }
  // --parsable: "ID" or "ID;CLUSTER" on the last line (warnings come before it).
  std::string last = engine::io::trim(r.output);
  if (const std::size_t nl = last.rfind('\n'); nl != std::string::npos) last = last.substr(nl + 1);
  SlurmJob job;
  if (!parse_job(last, &job)) {
    throw InputError("--slurm", "sbatch answered no job ID: " + one_line(r.output));
  }
  std::ofstream(dir + "/slurm.job") << last << "\n";
  return job;
}

namespace {

// The job's tasks squeue still lists (queued or running).
struct JobState {
  int pending = 0, running = 0;
  bool squeue_failed = false;
  std::string error;
};

JobState job_state(const SlurmJob& job) {
  JobState s;
  const ShellResult r = run_shell("squeue --noheader --array --jobs " + job.id + " --format=%T" +
                                  (job.cluster.empty() ? "" : " --clusters " + job.cluster));
  if (r.exit_code != 0) {
    // A job squeue no longer knows (ended longer ago than MinJobAge) is over.
    if (r.output.find("Invalid job id") != std::string::npos) return s;
    s.squeue_failed = true;
    s.error = one_line(r.output);
    return s;
  }
  std::istringstream lines(r.output);
  for (std::string line; std::getline(lines, line);) {
    line = engine::io::trim(line);
    if (line.rfind("CLUSTER:", 0) == 0) continue;  // --clusters' heading
    if (line == "PENDING" || line == "REQUEUED" || line == "REQUEUE_HOLD") {
      ++s.pending;
    } else if (!line.empty()) {
      ++s.running;  // RUNNING, CONFIGURING, COMPLETING, SUSPENDED, ...: not over
    }
  }
  return s;
}

}  // namespace

bool wait_for_slurm_job(const SlurmJob& job, const SweepPlan& plan, const std::atomic<bool>& stop) {
  const bool tty = isatty(STDERR_FILENO) != 0;
  auto last_answer = std::chrono::steady_clock::now();
  while (!stop.load()) {
    const JobState s = job_state(job);
    const auto now = std::chrono::steady_clock::now();
    if (s.squeue_failed) {
      if (now - last_answer > std::chrono::seconds(60)) {
        throw InputError("squeue",
                         "failed for a minute following job " + job.text() + ": " + s.error);
      }
    } else {
      last_answer = now;
      if (s.pending + s.running == 0) break;
    }
    if (tty) {
      std::size_t done = 0, failed = 0;
      for (const std::size_t i : plan.to_run) {
        done += fs::exists(plan.file(i, ".h5"));
        failed += fs::exists(plan.file(i, ".failed"));
      }
      std::fprintf(stderr,
                   "\rsweep: Slurm job %s: %zu/%zu rows run, %zu failed; %d tasks running, %d "
                   "queued   ",
                   job.text().c_str(), done + failed, plan.to_run.size(), failed, s.running,
                   s.pending);
    }
    for (int k = 0; k < 20 && !stop.load(); ++k) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
  if (tty) std::fprintf(stderr, "\n");
  return !stop.load();
}

SlurmJobLeft slurm_job_left(const std::string& dir) {
  SlurmJobLeft left;
  const std::string path = dir + "/slurm.job";
  if (!fs::is_regular_file(path)) return left;
  if (!parse_job(engine::read_text_file(path), &left.job)) {
    left.unknown = path + " names no job";
    return left;
  }
  left.has_job = true;
  const JobState s = job_state(left.job);
  if (s.squeue_failed) {
    left.unknown = "squeue: " + s.error;
  } else {
    left.tasks = s.pending + s.running;
  }
  return left;
}

}  // namespace hapvox::cli
